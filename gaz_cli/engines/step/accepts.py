"""The scenes the step engine accepts: its options in range (dt, drag, pair gravity,
softening, damped walls, extra planes, diagnostics' period) and every particle in front of the
extra planes. Pure Python: no compiled code is loaded.
"""

from __future__ import annotations

import math

import numpy as np

from gaz_cli.model.checks import check_option, field_error, is_real
from gaz_cli.model.scene import STEP_ONLY, Scene


def check_step_scene(scene: Scene) -> None:
    """The step engine's options in range, for a scene with ``engine = "step"``: a time step no
    longer than the run, hard walls, drag, pair gravity and softening >= 0, wall restitution in
    [0, 1], ``print_every`` a whole number, every extra plane well formed and leaving room for
    the largest particle."""
    if scene.dt is None:
        raise field_error("`engine` step needs a time step `dt` (seconds)")
    check_option("dt", scene.dt)
    if scene.dt > scene.duration:
        raise field_error(f"`dt` {scene.dt:g} s is longer than `duration` {scene.duration:g} s; "
                          "lower `dt` or raise `duration`")
    if scene.boundary != "walls":
        raise field_error("`engine` step works with hard walls only; drop `boundary` periodic "
                          "or use `engine` event")
    for name in STEP_ONLY:  # drag, pair_gravity, softening, wall_restitution, print_every... by their rules
        check_option(name, getattr(scene, name))
    rmax = max(float(sp.radius) for sp, _ in scene.components)
    for plane in scene.planes:
        check_plane(plane, scene.dim)
        check_plane_room(plane, scene.length, rmax)


def check_plane(plane, dim: int) -> None:
    """One extra wall of the step engine: (point (D,), inward normal (D,) not zero, restitution in [0, 1])."""
    try:
        point, normal, e = plane
        point, normal = [float(c) for c in point], [float(c) for c in normal]
    except (TypeError, ValueError):
        raise field_error(f"`planes` entry {plane!r} is not (point, normal, restitution)") from None
    if len(point) != dim or len(normal) != dim:
        raise field_error(f"`planes` entry {plane!r} needs {dim} coordinates for its point and its normal")
    if not all(math.isfinite(c) for c in point + normal):
        raise field_error(f"`planes` entry {plane!r} holds a non-finite coordinate")
    if not any(normal):
        raise field_error(f"`planes` entry {plane!r} has a zero normal; give the inward normal of the wall")
    if not is_real("restitution", e) or not 0.0 <= e <= 1.0:
        raise field_error(f"`planes` entry {plane!r}: restitution {e!r} is outside [0, 1] (1 elastic, 0 fully damped)")


def plane_room(plane, length: float, radius: float) -> float:
    """How far in front of extra ``plane`` (along its inward normal, beyond ``radius``) the centre
    of a particle of ``radius`` can be while inside the box [radius, length - radius]^D, m: the
    largest (c - point).n - radius over the corners c of that box; < 0 when no centre fits."""
    point, normal, _ = plane
    nrm = np.asarray(normal, dtype=float)
    nrm = nrm / np.linalg.norm(nrm)
    lo, hi = radius, length - radius
    return float(sum(max((lo - p) * n, (hi - p) * n) for p, n in zip(point, nrm))) - radius


def check_plane_room(plane, length: float, radius: float) -> None:
    """An extra plane must leave room in the box for the largest particle on its inner side
    (else the engine would push every particle to the plane's side, out of the box)."""
    if plane_room(plane, length, radius) < 0:
        raise field_error(f"`planes` entry {plane!r} leaves no room in the box for a particle of radius "
                          f"{radius:g} m on its inner side (the side its normal points to); move its point "
                          "or turn its normal towards the box")


def check_in_front_of_planes(scene: Scene, positions) -> None:
    """SceneError when a particle of ``positions`` (N, D) m starts behind one of the scene's extra
    planes or closer to it than its radius: the step engine would put it back on the plane's
    inner side in one step, through the others. Round-off allowed: 1e-9 of the box side."""
    if not scene.planes:
        return
    pos, radii = np.asarray(positions, dtype=float), scene.radii()
    for k, plane in enumerate(scene.planes):
        point, normal, _ = plane
        nrm = np.asarray(normal, dtype=float)
        nrm = nrm / np.linalg.norm(nrm)
        gap = (pos - np.asarray(point, dtype=float)) @ nrm - radii
        i = int(np.argmin(gap))
        if gap[i] < -1e-9 * scene.length:
            raise field_error(f"particle {i} starts behind `planes` entry {plane!r} (its centre "
                              f"{np.array2string(pos[i], precision=4)} m, {-gap[i]:.3g} m too far behind); "
                              + ("move it in front of the plane, or move the plane"
                                 if scene.initial is not None and scene.initial.get("kind") == "explicit" else
                                 "the placement fills the whole box, planes aside: give an `initial` state "
                                 "with every particle in front of the planes, or move the plane"))
