"""ROS map_server maps on disk: `load_map` reads YAML + image into an OccupancyGrid, `save_map`
writes one back.

Pixels are read as ROS 1 map_server (navigation/map_server, image_loader.cpp) reads them: the
channels are averaged (alpha included in trinary mode, excluded in scale and raw mode when the
image has an alpha channel), `negate: 1` flips the value, p = (255 - value) / 255 is the
occupancy probability; p > occupied_thresh is occupied, p < free_thresh is free, anything else is
unknown (trinary) or a graded value (scale; fully transparent pixels are unknown). In raw mode
the averaged value is the occupancy value itself: 0-99 free, 100 occupied, above 100 unknown.
hubero's grid is binary: occupied and unknown cells cannot be entered, graded cells can, as the
navigation stack's costmap (lethal threshold 100) treats them. Image rows are flipped so that
row 0 is the lowest y. Every failure is a MapError naming the file and the field.
"""

from __future__ import annotations

import contextlib
import math
import re
import struct
import warnings
import zlib
from dataclasses import dataclass
from enum import StrEnum
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import yaml
from PIL import Image

from hubero_dsl.diagnostics import Span
from hubero_dsl.errors import MapError
from hubero_dsl.files import read_bounded
from hubero_dsl.world.grid import MAX_MAP_CELLS, BoolArray, OccupancyGrid

UInt8Array = npt.NDArray[np.uint8]

REQUIRED_FIELDS = ("image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh")
EXAMPLE = ("image: map.pgm\nresolution: 0.05\norigin: [0.0, 0.0, 0.0]\nnegate: 0\n"
           "occupied_thresh: 0.65\nfree_thresh: 0.196")

PGM_MAGIC = b"P5"  # how a binary PGM, the image a map is saved as, starts
MAX_YAML_BYTES = 1 << 20          # a map YAML file is a few lines
MAX_RESOLUTION = 100.0            # m a cell: coarser is no floor plan a person walks on
MIN_RESOLUTION = 0.001            # m a cell: finer draws no furniture a person walks round
MAX_YAML_DEPTH = 32               # levels of nesting: a map or shape file needs a handful
MAX_IMAGE_BYTES = 512 << 20       # bytes of a map image file
SHOWN_VALUE = 60                  # characters of a field's value a message quotes

# What map_saver writes, so saved maps read back identically in ROS and here.
SAVED_OCCUPIED, SAVED_FREE, SAVED_UNKNOWN = 0, 254, 205
SAVED_OCCUPIED_THRESH, SAVED_FREE_THRESH = 0.65, 0.196


class MapMode(StrEnum):
    TRINARY = "trinary"
    SCALE = "scale"
    RAW = "raw"


@dataclass(frozen=True, slots=True)
class MapMetadata:
    """The checked fields of a map YAML file."""

    image: Path
    resolution: float
    origin: tuple[float, float, float]
    negate: bool
    occupied_thresh: float
    free_thresh: float
    mode: MapMode = MapMode.TRINARY


@dataclass(frozen=True, slots=True)
class _Document:
    """A parsed YAML mapping and where each of its fields sits in the file."""

    path: Path
    values: dict[str, Any]
    spans: dict[str, Span]

    def span(self, name: str) -> Span:
        return self.spans.get(name, Span.whole_file(str(self.path)))

    def error(self, name: str, message: str, hint: str | None = None) -> MapError:
        return MapError(f"field '{name}' of map {self.path} {message}", self.span(name), hint)


def shown(value: object) -> str:
    """A value as messages quote it: never more than SHOWN_VALUE characters."""
    text = repr(value)
    return text if len(text) <= SHOWN_VALUE else text[:SHOWN_VALUE - 3] + "..."


def load_map(path: str | Path) -> OccupancyGrid:
    """Read a ROS map_server map (YAML file naming a PGM/PNG/... image) into an OccupancyGrid."""
    document = _read_document(Path(path))
    metadata = _check_fields(document)
    channels, has_alpha = _read_image(metadata.image, document)
    occupied, unknown = classify_pixels(channels, has_alpha, metadata)
    # Image row 0 is the top of the map; grid row 0 is the lowest y.
    return OccupancyGrid(np.flipud(occupied), metadata.resolution, metadata.origin[:2],
                         source=str(document.path), unknown=np.flipud(unknown))


def map_files(path: str | Path) -> tuple[Path, ...]:
    """The files a map is read from: its YAML and the image it names (the YAML alone when it
    is no map file). No output may be written over them."""
    yaml_path = Path(path)
    try:
        return (yaml_path, _check_fields(_read_document(yaml_path)).image)
    except MapError:
        return (yaml_path,)


def is_map_file(path: str | Path) -> bool:
    """Whether `path` reads as a map YAML (a mapping of fields with an `image`), its fields
    right or not: what `hubero map draw` may write over."""
    try:
        _read_document(Path(path))
    except MapError:
        return False
    return True


# --- the YAML file ------------------------------------------------------------------------


def _read_document(path: Path) -> _Document:
    """The map YAML as fields. Messages quote the file (a span) only once it has been read as
    a map file: a mapping with an `image` field. A map path can name any file, and an error
    must not show a line of /etc/passwd."""
    with contextlib.suppress(OSError):  # a name too long, say: read_bounded words it
        if path.is_dir():
            raise MapError(f"map path is a directory, not a YAML file: {path}")
    data = read_bounded(path, MAX_YAML_BYTES, "map file", MapError)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise MapError(f"map file {path} is not UTF-8 text (byte {exc.start})") from None
    try:
        _refuse_aliases(path, text)
        root = yaml.compose(text, Loader=yaml.SafeLoader)
        values = yaml.safe_load(text)
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        where = f" (line {mark.line + 1}, column {mark.column + 1})" if mark else ""
        span = _mark_span(path, mark, mark) if mark and _looks_like_a_map(text) else None
        raise MapError(f"map file {path} is not valid YAML: {exc.problem}{where}",
                       span) from None
    except yaml.YAMLError:
        raise MapError(f"map file {path} is not valid YAML") from None
    if not isinstance(values, dict) or not isinstance(root, yaml.MappingNode) \
            or "image" not in values:
        raise MapError(f"{path} is not a map file: a map file is a YAML mapping of fields "
                       "with an `image`", hint=f"a map file looks like:\n{EXAMPLE}")
    spans = {key.value: _mark_span(path, value.start_mark, value.end_mark)
             for key, value in root.value if isinstance(key, yaml.ScalarNode)}
    return _Document(path, {str(k): v for k, v in values.items()}, spans)


_MAP_FIELD = re.compile(r"^\s*(image|resolution|origin|negate|occupied_thresh|free_thresh|mode)"
                        r"\s*:", re.MULTILINE)


def _looks_like_a_map(text: str) -> bool:
    """A broken map file is worth quoting at its error; any other file is not."""
    return _MAP_FIELD.search(text[:4096]) is not None


def _refuse_aliases(path: Path, text: str) -> None:
    """A map file's YAML must be safe to build (`unsafe_yaml`): refuse it before anything is
    built from the text."""
    unsafe = unsafe_yaml(text)
    if unsafe is not None:
        token, why = unsafe
        raise MapError(f"map file {path} {why} (line {token.start_mark.line + 1}); map files "
                       "may not")


_OPENS = (yaml.FlowSequenceStartToken, yaml.FlowMappingStartToken,
          yaml.BlockSequenceStartToken, yaml.BlockMappingStartToken)
_CLOSES = (yaml.FlowSequenceEndToken, yaml.FlowMappingEndToken, yaml.BlockEndToken)


def unsafe_yaml(text: str) -> tuple[yaml.Token, str] | None:
    """The first token that makes a YAML text unsafe to build, and why: anchors and aliases
    (nested ones expand exponentially, the 'billion laughs') and nesting deeper than
    MAX_YAML_DEPTH (PyYAML builds nodes recursively: a few kilobytes of brackets exhaust
    Python's stack). The scanner that finds them is not recursive."""
    depth = 0
    for token in yaml.scan(text, Loader=yaml.SafeLoader):
        if isinstance(token, yaml.AliasToken | yaml.AnchorToken):
            return token, "uses YAML anchors and aliases"
        if isinstance(token, _OPENS):
            depth += 1
            if depth > MAX_YAML_DEPTH:
                return token, f"nests deeper than {MAX_YAML_DEPTH} levels"
        elif isinstance(token, _CLOSES):
            depth -= 1
    return None


def _mark_span(path: Path, start: yaml.Mark, end: yaml.Mark) -> Span:
    return Span(str(path), start.line + 1, start.column + 1, end.line + 1, end.column + 1)


def _check_fields(document: _Document) -> MapMetadata:
    missing = [name for name in REQUIRED_FIELDS if name not in document.values]
    if missing:
        names = ", ".join(f"'{name}'" for name in missing)
        raise MapError(f"map file {document.path} lacks the required field(s) {names}",
                       Span.whole_file(str(document.path)),
                       hint=f"a map file looks like:\n{EXAMPLE}")
    resolution = _number(document, "resolution")
    if not MIN_RESOLUTION <= resolution <= MAX_RESOLUTION:
        raise document.error("resolution", f"must be {MIN_RESOLUTION:g} to {MAX_RESOLUTION:g} "
                             f"metres per cell, got {resolution:g}")
    occupied_thresh = _threshold(document, "occupied_thresh")
    free_thresh = _threshold(document, "free_thresh")
    if free_thresh > occupied_thresh:
        raise document.error("free_thresh", f"({free_thresh:g}) must not exceed "
                             f"occupied_thresh ({occupied_thresh:g})")
    return MapMetadata(_image_path(document), resolution, _origin(document),
                       _negate(document), occupied_thresh, free_thresh, _mode(document))


def _is_finite_number(value: object) -> bool:
    if not isinstance(value, int | float) or isinstance(value, bool):
        return False
    try:
        return math.isfinite(value)
    except OverflowError:  # an integer too large for a float
        return False


def _as_number(value: object) -> object:
    """YAML 1.1 reads 5e-2 (no dot) as text; ROS reads a number."""
    if isinstance(value, str):
        with contextlib.suppress(ValueError):
            return float(value)
    return value


def _number(document: _Document, name: str) -> float:
    value = _as_number(document.values[name])
    if not _is_finite_number(value):
        raise document.error(name, f"must be a number, got {shown(value)}")
    return float(value)  # type: ignore[arg-type]


def _threshold(document: _Document, name: str) -> float:
    value = _number(document, name)
    if not 0.0 <= value <= 1.0:
        raise document.error(name, f"must be a probability between 0 and 1, got {value:g}")
    return value


def _origin(document: _Document) -> tuple[float, float, float]:
    value = document.values["origin"]
    if isinstance(value, list):
        value = [_as_number(v) for v in value]
    if (not isinstance(value, list) or len(value) != 3
            or not all(_is_finite_number(v) for v in value)):
        raise document.error("origin", f"must be [x, y, yaw] in metres and radians, "
                             f"got {shown(value)}")
    x, y, yaw = (float(v) for v in value)
    if yaw != 0.0:
        raise document.error("origin", f"has yaw {yaw:g} rad; rotated maps are not supported",
                             hint="rotate the image so the map's x axis is horizontal and "
                                  "set the yaw to 0")
    return x, y, yaw


def _negate(document: _Document) -> bool:
    value = document.values["negate"]
    if value not in (0, 1) or isinstance(value, float):
        raise document.error("negate", f"must be 0 or 1, got {shown(value)}")
    return bool(value)


def _mode(document: _Document) -> MapMode:
    value = document.values.get("mode", MapMode.TRINARY.value)
    choices = [mode.value for mode in MapMode]
    if value not in choices:
        raise document.error("mode", f"must be one of {', '.join(choices)}, got {shown(value)}")
    return MapMode(value)


def _image_path(document: _Document) -> Path:
    value = document.values["image"]
    if not isinstance(value, str) or not value.strip():
        raise document.error("image", f"must be the path of an image file, got {shown(value)}")
    image = Path(value)
    return image if image.is_absolute() else document.path.parent / image


# --- the image ----------------------------------------------------------------------------


_SMALLER_MAP = "use a coarser resolution or crop the map to the part the scenario uses"


def _read_image(path: Path, document: _Document) -> tuple[UInt8Array, bool]:
    """(rows, cols, channels) uint8 pixels, and whether the last channel is alpha."""
    if not path.exists():
        raise document.error("image", f"names a file that does not exist: {path}")
    if path.is_dir():
        raise document.error("image", f"names a directory, not an image: {path}")
    if not path.is_file():
        raise document.error("image", f"names a device, a FIFO or a socket, not an image: "
                                       f"{path}")
    if path.stat().st_size > MAX_IMAGE_BYTES:
        raise document.error("image", f"is larger than {MAX_IMAGE_BYTES >> 20} MiB: {path}")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)  # sized just below
            with Image.open(path) as image:
                cols, rows = image.size
                if rows * cols > MAX_MAP_CELLS:
                    raise document.error("image", f"is {cols} x {rows} cells; a map has at "
                                         f"most {MAX_MAP_CELLS:,} (for example 4000 x 4000)",
                                         hint=_SMALLER_MAP)
                image.load()
                if image.format == "PNG":
                    _check_png_complete(path, document)
                return _channels(image, path, document)
    except MapError:
        raise
    except Image.DecompressionBombError:  # Pillow refuses to open it: beyond any limit of ours
        raise document.error("image", f"is far more than a map's {MAX_MAP_CELLS:,} cells (for "
                             f"example 4000 x 4000): {path}", hint=_SMALLER_MAP) from None
    except (OSError, ValueError, SyntaxError, EOFError) as exc:
        raise document.error("image", f"cannot be read: {path}: {exc}") from None


# Adam7's passes: (first column, first row, column step, row step).
_ADAM7 = ((0, 0, 8, 8), (4, 0, 8, 8), (0, 4, 4, 8), (2, 0, 4, 4), (0, 2, 2, 4), (1, 0, 2, 2),
          (0, 1, 1, 2))
_PNG_CHANNELS = {0: 1, 2: 3, 3: 1, 4: 2, 6: 4}   # by colour type


def _check_png_complete(path: Path, document: _Document) -> None:
    """Refuse a PNG whose compressed rows end early.

    Pillow fills the rows missing from a stream that ends cleanly with zeros, which a map
    reads as walls: a map cut short in a download would load, its lower part all occupied.
    The rows' bytes are counted here, from the header's size, up to the first byte too many.
    """
    data = path.read_bytes()
    position, width, height, expected, found = 8, 0, 0, 0, 0
    stream = zlib.decompressobj()
    while position + 8 <= len(data) and found <= expected:
        length, kind = struct.unpack(">I4s", data[position:position + 8])
        body = data[position + 8:position + 8 + length]
        position += 12 + length
        if kind == b"IHDR" and len(body) == 13:
            width, height, depth, colour, _, _, interlace = struct.unpack(">IIBBBBB", body)
            expected = _png_data_bytes(width, height, depth * _PNG_CHANNELS.get(colour, 1),
                                       interlaced=interlace == 1)
        elif kind == b"IDAT":
            with contextlib.suppress(zlib.error):   # Pillow has read what it could: count it
                found += len(stream.decompress(body, expected - found + 1))
    if found < expected:
        raise document.error("image", f"is cut short: its pixel data ends before its last "
                             f"rows ({found:,} of {expected:,} bytes of a {width} x {height} "
                             f"image): {path}")


def _png_data_bytes(width: int, height: int, bits: int, *, interlaced: bool) -> int:
    """Bytes of a PNG's filtered rows: a filter byte and the packed pixels, pass by pass."""
    passes = _ADAM7 if interlaced else ((0, 0, 1, 1),)
    total = 0
    for column, row, column_step, row_step in passes:
        columns = -(-(width - column) // column_step) if width > column else 0
        rows = -(-(height - row) // row_step) if height > row else 0
        if columns and rows:
            total += rows * (1 + -(-columns * bits // 8))
    return total


def _channels(image: Image.Image, path: Path, document: _Document) -> tuple[UInt8Array, bool]:
    if image.mode in ("I", "I;16", "I;16B", "I;16L", "I;16N"):
        return _sixteen_bit(np.asarray(image), path, document), False
    if image.mode == "1":
        image = image.convert("L")
    elif image.mode == "LA" or image.mode == "PA" or "transparency" in image.info:
        # SDL_image (what map_server reads with) expands grey + alpha and palettes to RGBA.
        image = image.convert("RGBA")
    elif image.mode not in ("L", "RGB", "RGBA"):
        image = image.convert("RGB")
    pixels = np.asarray(image, dtype=np.uint8)
    if pixels.ndim == 2:
        pixels = pixels[..., None]
    if pixels.shape[0] == 0 or pixels.shape[1] == 0:
        raise document.error("image", f"is empty: {path}")
    return pixels, image.mode == "RGBA"


def _sixteen_bit(values: npt.NDArray[Any], path: Path, document: _Document) -> UInt8Array:
    """16-bit grey reduced to 8 bits, as SDL_image does with such images."""
    if values.size and (values.min() < 0 or values.max() > 65535):
        raise document.error("image", f"has pixel values outside 0-65535: {path}")
    scaled = (values.astype(np.int64) * 255 + 32767) // 65535
    return scaled.astype(np.uint8)[..., None]


def classify_pixels(channels: UInt8Array, has_alpha: bool,
                    metadata: MapMetadata) -> tuple[BoolArray, BoolArray]:
    """(occupied, unknown) masks in image order, following map_server's pixel semantics.

    `occupied` includes unknown cells: neither may be entered.
    """
    count = channels.shape[-1]
    averaged = count - 1 if has_alpha and metadata.mode is not MapMode.TRINARY else count
    value = channels[..., :averaged].astype(np.float64).sum(axis=-1) / averaged
    if metadata.negate:
        value = 255.0 - value
    if metadata.mode is MapMode.RAW:
        raw = value.astype(np.uint8)  # map_server truncates the average to a byte
        return raw >= 100, raw > 100
    occupancy = (255.0 - value) / 255.0
    occupied = occupancy > metadata.occupied_thresh
    undecided = ~occupied & ~(occupancy < metadata.free_thresh)
    if metadata.mode is MapMode.TRINARY:
        unknown = undecided
    else:
        # Scale mode grades undecided pixels; only fully transparent ones are unknown.
        transparent = channels[..., -1] == 0 if has_alpha else np.zeros_like(occupied)
        unknown = undecided & transparent
    return occupied | unknown, unknown


# --- saving -------------------------------------------------------------------------------


def save_map(grid: OccupancyGrid, yaml_path: str | Path, *, comment: str | None = None) -> Path:
    """Write `grid` as map_server YAML + binary PGM (P5) next to it; returns the image path.

    Pixels are written as map_saver writes them: 0 occupied, 254 free, 205 unknown.
    """
    yaml_path = Path(yaml_path)
    image_path = yaml_path.with_suffix(".pgm")
    pixels = np.full(grid.shape, SAVED_FREE, dtype=np.uint8)
    pixels[grid.occupied] = SAVED_OCCUPIED
    if grid.unknown is not None:
        pixels[grid.unknown] = SAVED_UNKNOWN
    rows, cols = grid.shape
    header = (f"{PGM_MAGIC.decode()}\n# CREATOR: hubero {grid.resolution:.3f} m/pix\n"
              f"{cols} {rows}\n255\n")
    lines = [f"# {line}".rstrip() for line in (comment or "").splitlines()]
    lines += [f"image: {image_path.name}",
              f"resolution: {grid.resolution!r}",
              f"origin: [{grid.origin[0]!r}, {grid.origin[1]!r}, 0.0]",
              "negate: 0",
              f"occupied_thresh: {SAVED_OCCUPIED_THRESH!r}",
              f"free_thresh: {SAVED_FREE_THRESH!r}",
              f"mode: {MapMode.TRINARY.value}"]
    try:
        image_path.write_bytes(header.encode("ascii") + np.flipud(pixels).tobytes())
        yaml_path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    except OSError as exc:
        raise MapError(f"cannot write map {yaml_path}: {exc.strerror or exc}") from None
    return image_path
