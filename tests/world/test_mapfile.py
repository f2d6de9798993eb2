"""Map files: map_server pixel semantics, image formats, every bad input, and save/load."""

from __future__ import annotations

import struct
import zlib
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from PIL import Image

from hubero_dsl.errors import MapError
from hubero_dsl.world.grid import OccupancyGrid
from hubero_dsl.world.mapfile import load_map, save_map

FIELDS: dict[str, Any] = {"resolution": 0.5, "origin": [1.0, 2.0, 0.0], "negate": 0,
                          "occupied_thresh": 0.65, "free_thresh": 0.196}


def yaml_text(fields: dict[str, Any]) -> str:
    return "".join(f"{key}: {value}\n" for key, value in fields.items())


def write_pgm(path: Path, pixels: np.ndarray, *, ascii_format: bool) -> None:
    rows, cols = pixels.shape
    if ascii_format:
        body = "\n".join(" ".join(str(v) for v in row) for row in pixels)
        path.write_text(f"P2\n# a comment\n{cols} {rows}\n255\n{body}\n")
    else:
        path.write_bytes(f"P5\n{cols} {rows}\n255\n".encode() + pixels.astype(np.uint8).tobytes())


def write_map(directory: Path, pixels: np.ndarray, *, image_file: str = "map.pgm",
              ascii_format: bool = False, **overrides: Any) -> Path:
    """A map YAML + image; pixels are in image order (first row = top of the map).

    `overrides` replace or add YAML fields (including `image`).
    """
    image_path = directory / image_file
    image_path.parent.mkdir(parents=True, exist_ok=True)
    if image_path.suffix == ".pgm":
        write_pgm(image_path, pixels, ascii_format=ascii_format)
    else:
        Image.fromarray(pixels.astype(np.uint8)).save(image_path)
    yaml_path = directory / "map.yaml"
    yaml_path.write_text(yaml_text({"image": image_file, **FIELDS, **overrides}))
    return yaml_path


def classes(grid: OccupancyGrid) -> list[str]:
    """Each cell in image order (top row first) as 'occ', 'unk' or 'free'."""
    unknown = grid.unknown if grid.unknown is not None else np.zeros(grid.shape, dtype=bool)
    labels = np.where(unknown, "unk", np.where(grid.occupied, "occ", "free"))
    return [str(v) for v in np.flipud(labels).ravel()]


# --- reading --------------------------------------------------------------------------------


@pytest.mark.parametrize(("image", "ascii_format"), [("map.pgm", True), ("map.pgm", False),
                                                     ("map.png", False)])
def test_formats_read_the_same_with_row_zero_at_the_bottom(tmp_path: Path, image: str,
                                                           ascii_format: bool) -> None:
    pixels = np.array([[0, 0, 0], [254, 254, 254], [254, 205, 254], [254, 254, 0]])
    grid = load_map(write_map(tmp_path, pixels, image_file=image, ascii_format=ascii_format))
    assert grid.shape == (4, 3)
    assert grid.resolution == 0.5 and grid.origin == (1.0, 2.0)
    assert grid.occupied[3].all() and not grid.occupied[2].any()  # top image row = highest y
    assert grid.occupied[0].tolist() == [False, False, True]
    assert grid.unknown is not None and grid.unknown[1, 1] and grid.occupied[1, 1]
    assert not grid.is_free((1.25, 3.75)) and grid.is_free((1.25, 2.25))
    assert grid.source == str(tmp_path / "map.yaml")


def test_trinary_thresholds_are_strict(tmp_path: Path) -> None:
    # p = (255 - v) / 255: v = 89 -> 0.651 > 0.65 occupied; v = 90 -> 0.647 unknown;
    # v = 205 -> 0.19608 (not < 0.196) unknown; v = 206 -> 0.192 free.
    pixels = np.array([[89, 90, 205, 206, 255, 0]])
    grid = load_map(write_map(tmp_path, pixels))
    assert classes(grid) == ["occ", "unk", "unk", "free", "free", "occ"]


def test_negate_swaps_black_and_white(tmp_path: Path) -> None:
    grid = load_map(write_map(tmp_path, np.array([[0, 255, 128]]), negate=1))
    assert classes(grid) == ["free", "occ", "unk"]


def test_colour_channels_are_averaged(tmp_path: Path) -> None:
    pixels = np.array([[[255, 0, 0], [255, 255, 0], [250, 250, 250]]], dtype=np.uint8)
    grid = load_map(write_map(tmp_path, pixels, image_file="map.png"))
    # averages 85 (p 0.67), 170 (p 0.33), 250 (p 0.02)
    assert classes(grid) == ["occ", "unk", "free"]


def rgba_pixels() -> np.ndarray:
    return np.array([[[255, 255, 255, 0], [0, 0, 0, 0], [128, 128, 128, 0],
                      [128, 128, 128, 255], [255, 255, 255, 255]]], dtype=np.uint8)


def test_trinary_mode_averages_alpha_in_like_map_server(tmp_path: Path) -> None:
    grid = load_map(write_map(tmp_path, rgba_pixels(), image_file="map.png"))
    # white transparent: (3*255 + 0)/4 = 191.25 -> p 0.25 -> unknown, not free;
    # grey transparent: 96 -> p 0.62 -> unknown; grey opaque: 159.75 -> p 0.37 -> unknown
    assert classes(grid) == ["unk", "occ", "unk", "unk", "free"]


def test_scale_mode_ignores_alpha_in_the_average_and_makes_transparent_grey_unknown(
        tmp_path: Path) -> None:
    grid = load_map(write_map(tmp_path, rgba_pixels(), image_file="map.png", mode="scale"))
    # grey opaque is a graded (walkable) value in scale mode; grey transparent is unknown
    assert classes(grid) == ["free", "occ", "unk", "free", "free"]


def test_grey_with_alpha_reads_like_rgba(tmp_path: Path) -> None:
    grey_alpha = np.array([[[255, 0], [0, 255], [255, 255]]], dtype=np.uint8)
    grid = load_map(write_map(tmp_path, grey_alpha, image_file="map.png"))
    assert classes(grid) == ["unk", "occ", "free"]


def test_raw_mode_uses_the_value_directly(tmp_path: Path) -> None:
    grid = load_map(write_map(tmp_path, np.array([[0, 99, 100, 101, 255]]), mode="raw"))
    assert classes(grid) == ["free", "free", "occ", "unk", "unk"]


def test_raw_mode_with_negate(tmp_path: Path) -> None:
    grid = load_map(write_map(tmp_path, np.array([[255, 155, 0]]), mode="raw", negate=1))
    assert classes(grid) == ["free", "occ", "unk"]


def test_sixteen_bit_pgm_is_reduced_to_eight_bits(tmp_path: Path) -> None:
    path = tmp_path / "map.pgm"
    path.write_bytes(b"P5\n3 1\n65535\n" + np.array([0, 40000, 65535], dtype=">u2").tobytes())
    yaml_path = tmp_path / "map.yaml"
    yaml_path.write_text(yaml_text({"image": "map.pgm", **FIELDS}))
    assert classes(load_map(yaml_path)) == ["occ", "unk", "free"]


def test_image_path_is_relative_to_the_yaml_file(tmp_path: Path,
                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    yaml_path = write_map(tmp_path, np.array([[0, 255]]), image_file="images/map.pgm")
    monkeypatch.chdir(tmp_path / "images")
    assert classes(load_map(yaml_path)) == ["occ", "free"]


def test_absolute_image_path(tmp_path: Path) -> None:
    write_map(tmp_path / "elsewhere", np.array([[255, 0]]))
    yaml_path = tmp_path / "abs.yaml"
    yaml_path.write_text(yaml_text({"image": str(tmp_path / "elsewhere" / "map.pgm"), **FIELDS}))
    assert classes(load_map(yaml_path)) == ["free", "occ"]


def test_mode_trinary_written_out_and_extra_fields_are_accepted(tmp_path: Path) -> None:
    yaml_path = write_map(tmp_path, np.array([[0, 255]]), mode="trinary", comment="'x'")
    assert classes(load_map(yaml_path)) == ["occ", "free"]


# --- bad input ------------------------------------------------------------------------------

GOOD = np.array([[0, 255], [255, 255]])


def expect_map_error(yaml_path: Path, *fragments: str) -> MapError:
    with pytest.raises(MapError) as caught:
        load_map(yaml_path)
    text = str(caught.value)
    assert yaml_path.name in caught.value.message
    for fragment in fragments:
        assert fragment in text
    return caught.value


@pytest.mark.parametrize(("field", "value", "fragment"), [
    ("resolution", 0, "must be 0.001 to 100 metres per cell, got 0"),
    ("resolution", -0.05, "must be 0.001 to 100 metres per cell"),
    ("resolution", 1e-300, "got 1e-300"),  # a map of 7e-298 m was accepted
    ("resolution", 1000, "must be 0.001 to 100 metres per cell"),
    ("resolution", "abc", "must be a number"),
    ("resolution", ".nan", "must be a number"),
    ("resolution", "true", "must be a number"),
    ("origin", "[0.0, 0.0]", "[x, y, yaw]"),
    ("origin", "[a, 0.0, 0.0]", "[x, y, yaw]"),
    ("origin", "7", "[x, y, yaw]"),
    ("origin", "[0.0, 0.0, 0.5]", "yaw"),
    ("negate", 2, "0 or 1"),
    ("negate", "yes please", "0 or 1"),
    ("occupied_thresh", 1.5, "between 0 and 1"),
    ("free_thresh", -0.1, "between 0 and 1"),
    ("free_thresh", 0.9, "must not exceed occupied_thresh"),
    ("occupied_thresh", "[1]", "must be a number"),
    ("mode", "fancy", "trinary, scale, raw"),
    ("image", 5, "path of an image"),
    ("image", "''", "path of an image"),
])
def test_bad_fields(tmp_path: Path, field: str, value: Any, fragment: str) -> None:
    yaml_path = write_map(tmp_path, GOOD, **{field: value})
    error = expect_map_error(yaml_path, f"'{field}'", fragment)
    lines = yaml_path.read_text().splitlines()
    line = next(n for n, text in enumerate(lines, 1) if text.startswith(f"{field}:"))
    assert error.span is not None  # points at the field's value
    assert (error.span.line, error.span.column) == (line, len(field) + 3)


def test_yaw_error_says_what_to_do(tmp_path: Path) -> None:
    error = expect_map_error(write_map(tmp_path, GOOD, origin="[0, 0, 1.57]"), "origin")
    assert error.hint is not None and "rotate" in error.hint


def test_missing_fields_are_listed(tmp_path: Path) -> None:
    yaml_path = tmp_path / "map.yaml"
    yaml_path.write_text("image: map.pgm\nresolution: 0.05\n")
    expect_map_error(yaml_path, "'origin'", "'negate'", "'occupied_thresh'", "'free_thresh'")


def test_missing_yaml_file(tmp_path: Path) -> None:
    expect_map_error(tmp_path / "nothing.yaml", "not found")


def test_yaml_path_is_a_directory(tmp_path: Path) -> None:
    directory = tmp_path / "map.yaml"
    directory.mkdir()
    expect_map_error(directory, "directory")


def test_yaml_syntax_error_points_at_the_line(tmp_path: Path) -> None:
    yaml_path = tmp_path / "map.yaml"
    yaml_path.write_text("image: map.pgm\nresolution: [0.05\nnegate: 0\n")
    error = expect_map_error(yaml_path, "not valid YAML")
    assert error.span is not None and error.span.line >= 2


@pytest.mark.parametrize("text", ["", "- a\n- b\n", "just a string\n"])
def test_yaml_that_is_not_a_mapping(tmp_path: Path, text: str) -> None:
    yaml_path = tmp_path / "map.yaml"
    yaml_path.write_text(text)
    expect_map_error(yaml_path, "mapping")


def test_binary_yaml_file(tmp_path: Path) -> None:
    yaml_path = tmp_path / "map.yaml"
    yaml_path.write_bytes(b"\xff\xfe\x00garbage")
    expect_map_error(yaml_path, "UTF-8")


def test_missing_image(tmp_path: Path) -> None:
    yaml_path = tmp_path / "map.yaml"
    yaml_path.write_text(yaml_text({"image": "gone.pgm", **FIELDS}))
    expect_map_error(yaml_path, "'image'", "gone.pgm", "does not exist")


def test_image_is_a_device(tmp_path: Path) -> None:
    # "field 'image' of map map.yaml map image /dev/zero is not a regular file"
    yaml_path = tmp_path / "map.yaml"
    yaml_path.write_text(yaml_text({"image": "/dev/zero", **FIELDS}))
    error = expect_map_error(yaml_path, "'image'", "names a device, a FIFO or a socket, not an "
                             "image: /dev/zero")
    assert "map image" not in error.message


def test_image_is_a_directory(tmp_path: Path) -> None:
    (tmp_path / "map.pgm").mkdir()
    yaml_path = tmp_path / "map.yaml"
    yaml_path.write_text(yaml_text({"image": "map.pgm", **FIELDS}))
    expect_map_error(yaml_path, "'image'", "directory")


@pytest.mark.parametrize("content", [
    b"",                                          # empty
    b"this is not an image at all",               # garbage
    b"P5\n4 4\n255\n" + bytes(7),                 # truncated binary PGM
    b"P5\n4 4\n",                                 # header only
    b"P2\n2 2\n255\n0 255\n128\n",                # truncated ASCII PGM
    b"P2\n2 2\n255\n0 255\n128 abc\n",            # garbage in ASCII PGM
    b"P2\n2 2\n255\n0 255\n128 300\n",            # value above maxval
    b"\x89PNG\r\n\x1a\n" + bytes(20),             # corrupt PNG
])
def test_corrupt_images(tmp_path: Path, content: bytes) -> None:
    (tmp_path / "map.pgm").write_bytes(content)
    yaml_path = tmp_path / "map.yaml"
    yaml_path.write_text(yaml_text({"image": "map.pgm", **FIELDS}))
    expect_map_error(yaml_path, "'image'", "map.pgm", "cannot be read")


def png_bytes(pixels: np.ndarray, *, rows_kept: int | None = None,
              interlaced: bool = False) -> bytes:
    """An 8-bit grey PNG written by hand: optionally Adam7-interlaced, or with its compressed
    data ending cleanly after `rows_kept` rows (what a cut download or a faulty writer gives)."""
    def chunk(kind: bytes, body: bytes) -> bytes:
        return (struct.pack(">I", len(body)) + kind + body
                + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF))

    passes = ([(0, 0, 8, 8), (4, 0, 8, 8), (0, 4, 4, 8), (2, 0, 4, 4), (0, 2, 2, 4),
               (1, 0, 2, 2), (0, 1, 1, 2)] if interlaced else [(0, 0, 1, 1)])
    rows = [row for column, first, column_step, row_step in passes
            for row in pixels[first::row_step, column::column_step].astype(np.uint8) if row.size]
    data = b"".join(b"\x00" + row.tobytes() for row in rows[:rows_kept])
    header = struct.pack(">IIBBBBB", pixels.shape[1], pixels.shape[0], 8, 0, 0, 0,
                         int(interlaced))
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(data))
            + chunk(b"IEND", b""))


def a_floor_plan() -> np.ndarray:
    pixels = np.full((13, 11), 254)
    pixels[0], pixels[:, 0], pixels[5, 3:9] = 0, 0, 0
    return pixels


def test_a_png_cut_short_is_refused_not_read_as_walls(tmp_path: Path) -> None:
    # Pillow reads the missing rows as black (occupied) without a word
    (tmp_path / "map.png").write_bytes(png_bytes(a_floor_plan(), rows_kept=4))
    yaml_path = tmp_path / "map.yaml"
    yaml_path.write_text(yaml_text({"image": "map.png", **FIELDS}))
    expect_map_error(yaml_path, "'image'", "map.png", "cut short", "48 of 156 bytes",
                     "11 x 13")


@pytest.mark.parametrize("interlaced", [False, True])
def test_whole_pngs_read_interlaced_or_not(tmp_path: Path, interlaced: bool) -> None:
    (tmp_path / "map.png").write_bytes(png_bytes(a_floor_plan(), interlaced=interlaced))
    yaml_path = tmp_path / "map.yaml"
    yaml_path.write_text(yaml_text({"image": "map.png", **FIELDS}))
    expected = load_map(write_map(tmp_path / "pgm", a_floor_plan()))
    assert np.array_equal(load_map(yaml_path).occupied, expected.occupied)


@pytest.mark.parametrize("mode", ["1", "L", "LA", "P", "RGB", "RGBA", "I;16"])
def test_pngs_of_every_mode_pillow_writes_are_whole(tmp_path: Path, mode: str) -> None:
    image = Image.fromarray(a_floor_plan().astype(np.uint8)).convert(mode)
    image.save(tmp_path / "map.png")
    yaml_path = tmp_path / "map.yaml"
    yaml_path.write_text(yaml_text({"image": "map.png", **FIELDS}))
    assert load_map(yaml_path).occupied[-1].all()       # the top row is a wall in every mode


# --- saving ---------------------------------------------------------------------------------


def test_save_then_load_gives_the_same_grid(tmp_path: Path) -> None:
    rng = np.random.default_rng(7)
    occupied = rng.random((13, 17)) < 0.3
    unknown = rng.random((13, 17)) < 0.1
    grid = OccupancyGrid(occupied, 0.05, (-18.0, -15.0), unknown=unknown)
    image_path = save_map(grid, tmp_path / "saved.yaml", comment="first line\nsecond line")
    assert image_path == tmp_path / "saved.pgm"
    assert image_path.read_bytes().startswith(b"P5\n")
    assert (tmp_path / "saved.yaml").read_text().startswith("# first line\n# second line\n")
    loaded = load_map(tmp_path / "saved.yaml")
    assert (loaded.occupied == grid.occupied).all()
    assert loaded.unknown is not None and (loaded.unknown == unknown).all()
    assert loaded.resolution == 0.05 and loaded.origin == (-18.0, -15.0)


def test_saved_pixels_are_what_map_saver_writes(tmp_path: Path) -> None:
    occupied = np.array([[True, False, False]])
    unknown = np.array([[False, False, True]])
    save_map(OccupancyGrid(occupied, 0.1, (0, 0), unknown=unknown), tmp_path / "m.yaml")
    assert (tmp_path / "m.pgm").read_bytes().endswith(bytes([0, 254, 205]))


def test_save_into_a_missing_directory_is_a_map_error(tmp_path: Path) -> None:
    grid = OccupancyGrid(np.zeros((2, 2), dtype=bool), 0.1, (0, 0))
    with pytest.raises(MapError, match="cannot write"):
        save_map(grid, tmp_path / "missing" / "m.yaml")


def test_numbers_written_as_ros_reads_them(tmp_path: Path) -> None:
    """YAML 1.1 reads `2e-2` and `-65e-1` (no dot) as text; ROS's map_server reads numbers."""
    save_map(OccupancyGrid(np.zeros((20, 20), dtype=bool), 0.05, (0.0, 0.0), "m"),
             tmp_path / "m.yaml")
    text = (tmp_path / "m.yaml").read_text(encoding="utf-8")
    text = "\n".join(line for line in text.splitlines()
                     if not line.startswith(("resolution:", "origin:")))
    (tmp_path / "m.yaml").write_text(text + "\nresolution: 5e-2\norigin: [-65e-1, 1e0, 0]\n",
                                     encoding="utf-8")
    grid = load_map(tmp_path / "m.yaml")
    assert grid.resolution == 0.05 and grid.origin == (-6.5, 1.0)


def test_an_image_too_large_for_pillow_to_open_says_what_a_map_may_be(tmp_path: Path) -> None:
    import struct
    import zlib

    def chunk(kind: bytes, data: bytes) -> bytes:
        return (struct.pack(">I", len(data)) + kind + data
                + struct.pack(">I", zlib.crc32(kind + data)))

    # a header claiming 30,000 x 30,000 pixels: Pillow refuses it as a decompression bomb
    header = struct.pack(">IIBBBBB", 30000, 30000, 8, 0, 0, 0, 0)
    (tmp_path / "huge.png").write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header)
                                        + chunk(b"IEND", b""))
    yaml_path = tmp_path / "huge.yaml"
    yaml_path.write_text(yaml_text({"image": "huge.png", **FIELDS}))
    with pytest.raises(MapError, match="is far more than a map's 16,000,000 cells"):
        load_map(yaml_path)
