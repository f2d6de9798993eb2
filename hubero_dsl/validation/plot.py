"""The fundamental diagram of recordings and their rebuilds in one picture (matplotlib Agg).

Left: speed against Voronoi density, right: specific flow against Voronoi density; each frame
a faint point (measured: circles, simulated: crosses), each density bin's mean a line, one
colour per recording.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from matplotlib.figure import Figure

from hubero_dsl.analysis.plot import colours, save
from hubero_dsl.files import write_replacing

if TYPE_CHECKING:
    from hubero_dsl.validation.validate import Validation


def plot_fundamental_diagram(results: Sequence[Validation], out: Path) -> Path:
    """Draw the diagram to `out` (PNG), written under a temporary name and renamed."""
    figure = Figure(figsize=(11.0, 4.8))
    speed_axes, flow_axes = figure.subplots(1, 2)
    palette = colours([r.comparison.name for r in results])
    for result in results:
        colour = palette[result.comparison.name]
        for diagram, marker, style, side in ((result.measured.diagram, "o", "-", "measured"),
                                             (result.simulated, "x", "--", "simulated")):
            frames = diagram.frames
            for axes, column in ((speed_axes, "voronoi_speed"), (flow_axes, "flow")):
                axes.scatter(frames["voronoi_density"], frames[column], s=4, marker=marker,
                             color=colour, alpha=0.12, linewidths=0.6)
            bins = [b for b in result.comparison.bins
                    if (b.measured_frames if side == "measured" else b.simulated_frames)]
            centres = [(b.low + b.high) / 2 for b in bins]
            speeds = [b.measured_speed if side == "measured" else b.simulated_speed
                      for b in bins]
            flows = [b.measured_flow if side == "measured" else b.simulated_flow for b in bins]
            label = f"{result.comparison.name} {side}"
            speed_axes.plot(centres, speeds, style, color=colour, label=label, linewidth=1.5)
            flow_axes.plot(centres, flows, style, color=colour, linewidth=1.5)
    speed_axes.set(xlabel="Voronoi density (1/m²)", ylabel="speed (m/s)", xlim=(0, None),
                   ylim=(0, None), title="speed (solid: measured, dashed: hubero)")
    flow_axes.set(xlabel="Voronoi density (1/m²)", ylabel="specific flow (1/(m s))",
                  xlim=(0, None), ylim=(0, None), title="flow")
    speed_axes.legend(fontsize=6, loc="upper right")
    figure.tight_layout()
    return write_replacing(out, lambda temp: save(figure, temp))
