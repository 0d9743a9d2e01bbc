"""Animated GIF of a trajectory (the animation of seed 003), with matplotlib.

:func:`render_gif` reads a trajectory written by :mod:`gaz_cli.outputs.trajectory`
(H5MD, GSD or VTK: :func:`~gaz_cli.outputs.trajectory.read_trajectory`) and draws every particle as a disk of its true
radius in the box, coloured by species, one frame per snapshot. 1D rods are
drawn on a line; 3D runs are drawn as their side view (x horizontal, the
gravity axis z vertical). In a periodic box a disk across an edge is drawn on both
sides, as the particle and its periodic image (:func:`periodic_images`). Particles smaller
than about a pixel get a dot so they stay visible (the comet of the ``comet`` preset is
5.5 km wide in a 1e9 m box); ``trail`` draws the path of the last frames of each particle.
"""

from __future__ import annotations

import os

import numpy as np

from gaz_cli.errors import OutputError, SceneError

MAX_FRAMES = 400
"""At most this many frames: longer trajectories are subsampled evenly."""

GIF_SUFFIXES = (".gif",)
"""Extensions of the animations written (matplotlib's PillowWriter, animated GIF)."""


def check_output(gif_path) -> None:
    """Raise OutputError unless ``gif_path`` names a format :func:`render_gif` writes."""
    if not str(gif_path).strip():
        raise OutputError(f"-o {str(gif_path)!r} names no file; give one such as run.gif, or drop -o "
                          "to write the trajectory's name with .gif")
    suffix = os.path.splitext(str(gif_path))[1].lower()
    if suffix not in GIF_SUFFIXES:
        raise OutputError(f"-o {str(gif_path)!r}: gaz animate writes {', '.join(GIF_SUFFIXES)} files only; "
                          f"name the output like run.gif")


def _frames(count: int, max_frames: int) -> np.ndarray:
    if count <= max_frames:
        return np.arange(count)
    return np.unique(np.linspace(0, count - 1, max_frames).round().astype(int))


def periodic_images(xy: np.ndarray, length: float, axes: int) -> np.ndarray:
    """The drawn centres of a periodic run: (T, N, 2) plane coordinates -> (T, 3^axes N, 2),
    each particle then its images shifted by -L, 0, +L along the first ``axes`` plane axes
    (1 for rods on a line, 2 for disks and the side view of spheres). The axes clip what falls
    outside the box, so a disk across an edge shows on both sides; a particle's image k is at
    index k N + i, the unshifted one first."""
    steps = (0.0, -length, length)
    shifts = [(dx, dy) for dx in steps for dy in (steps if axes == 2 else (0.0,))]
    return np.concatenate([xy + np.array(shift) for shift in shifts], axis=1)


def _figure(data: dict, size_px: int, dpi: int):
    """Figure, axes, the plane coordinates (T, N, 2) and a title prefix."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    dim = data["dim"]
    pos = data["positions"]
    length = float(np.max(data["box"]))
    radius = np.asarray(data["radius"], dtype=float)
    if dim == 1:
        xy = np.stack([pos[:, :, 0], np.zeros(pos.shape[:2])], axis=2)
        half = max(3.0 * float(radius.max(initial=0.0)), 0.04 * length)
        fig, ax = plt.subplots(figsize=(size_px / dpi, size_px / dpi * 0.35), dpi=dpi)
        ax.set_xlim(0, length)
        ax.set_ylim(-half, half)
        ax.set_yticks([])
        ax.axhline(0.0, color="0.85", lw=0.5, zorder=0)
    else:
        xy = pos[:, :, [0, dim - 1]]
        fig, ax = plt.subplots(figsize=(size_px / dpi, size_px / dpi), dpi=dpi)
        ax.set_xlim(0, length)
        ax.set_ylim(0, length)
        ax.set_ylabel("z (m)" if dim == 3 else "y (m)")
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    for side in ax.spines.values():
        side.set_linewidth(1.5)
    return fig, ax, xy


def render_gif(trajectory_path: str | os.PathLike, gif_path: str | os.PathLike, fps: int = 20,
               max_frames: int = MAX_FRAMES, size_px: int = 600, dpi: int = 100, trail: int = 0,
               frame_png: str | os.PathLike | None = None) -> int:
    """Render the trajectory ``trajectory_path`` (.h5md, .gsd or .pvd) to the animated GIF ``gif_path``.

    fps: frames per second of the GIF; max_frames: subsample longer
    trajectories; size_px: width of the image in pixels; trail: number of
    past frames drawn as a line behind each particle (0: none; meant for a
    few bodies). frame_png: also save the last frame as a PNG. Returns the
    number of frames written. Raises SceneError for a file that is not a
    trajectory or has no snapshot, OutputError for an output that is not a .gif.
    """
    from matplotlib.animation import FuncAnimation, PillowWriter
    from matplotlib.collections import EllipseCollection

    from gaz_cli.outputs.trajectory import read_trajectory

    check_output(gif_path)
    data = read_trajectory(trajectory_path)
    count = data["positions"].shape[0]
    if count == 0:
        raise SceneError(f"trajectory {str(trajectory_path)!r} holds no snapshot")
    fig, ax, xy = _figure(data, size_px, dpi)
    radius = np.asarray(data["radius"], dtype=float)
    species = data["species"] if data["species"] is not None else np.zeros(radius.size, int)
    colours = np.array([f"C{k % 10}" for k in species])
    names = data["species_names"]
    centres, copies = xy, 1
    if data.get("periodic"):  # each disk and its images: one across an edge shows on both sides
        centres = periodic_images(xy, float(np.max(data["box"])), 1 if data["dim"] == 1 else 2)
        copies = centres.shape[1] // radius.size
    size = np.tile(2 * radius, copies)
    disks = EllipseCollection(size, size, np.zeros_like(size), units="xy",
                              offsets=centres[0], offset_transform=ax.transData,
                              facecolors=np.tile(colours, copies), edgecolors="k", linewidths=0.3)
    ax.add_collection(disks)
    # particles under ~1.5 pixel wide: a dot on top
    fig.canvas.draw()
    px_per_m = ax.get_window_extent().width / (ax.get_xlim()[1] - ax.get_xlim()[0])
    tiny = radius * px_per_m < 1.5
    dots = ax.scatter(xy[0, tiny, 0], xy[0, tiny, 1], s=9, c=colours[tiny], zorder=3) if tiny.any() else None
    lines = []
    if trail > 0:
        lines = [ax.plot([], [], lw=0.8, color=colours[i], alpha=0.7)[0] for i in range(radius.size)]
    for k, name in enumerate(names):
        if np.any(species == k):
            ax.plot([], [], "o", color=f"C{k % 10}", label=name)
    if len(names) > 1:
        if data["dim"] == 1:
            ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
        else:
            ax.legend(loc="upper right", fontsize=8)
    title = ax.set_title("")
    frames = _frames(count, max_frames)

    def draw(k):
        disks.set_offsets(centres[k])
        if dots is not None:
            dots.set_offsets(xy[k, tiny])
        if lines:
            lo = max(0, k - trail)
            for i, line in enumerate(lines):
                line.set_data(xy[lo:k + 1, i, 0], xy[lo:k + 1, i, 1])
        title.set_text(f"t = {data['time'][k]:.4g} s")
        return [disks, title]

    anim = FuncAnimation(fig, draw, frames=frames, blit=False)
    from gaz_cli import atomic

    try:
        with atomic.replacing(gif_path) as name:  # whole or not at all: the old GIF kept
            anim.save(str(name), writer=PillowWriter(fps=fps))
        if frame_png is not None:
            draw(frames[-1])
            fig.savefig(frame_png)
    except OSError as err:
        raise SceneError(f"cannot write {str(gif_path)!r}: {err}") from None
    finally:
        import matplotlib.pyplot as plt

        plt.close(fig)
    return int(frames.size)
