"""Pictures of a body run: the deformed body coloured by its von Mises stress at the
first contact's start, its peak force and its release (`snapshot_figure`), and a movie of
the run beside its contact force (`write_movie`, GIF or MP4 through imageio).

2D bodies are drawn in their plane (true scale: the displacement is not magnified; the
colour shows the stress); 3D bodies as a cut-away: the elements behind the body's middle
plane, seen from the cut side (a section through the middle, the surface behind it).
`RunPictures` keeps what the pictures need from a run while its samples are at hand
(the displacement at the three instants and at up to `MOVIE_FRAMES` samples), so that
the run's samples can go.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from contact_bench.output.fields import BodyFields

#: samples a movie shows at most (evenly spaced over the run)
MOVIE_FRAMES = 120
SNAPSHOT_NAMES = ("contact start", "peak force", "release")


@dataclass(frozen=True)
class RunPictures:
    """A run's picture data: its `BodyFields`, sample times and total contact force,
    the obstacle (axis and level), the snapshot samples and (for a movie) frames."""

    title: str
    fields: BodyFields
    t: np.ndarray
    force: np.ndarray
    axis: int
    level: float
    snapshots: tuple[int, ...]  # sample indices: contact start, peak force, release
    snap_U: np.ndarray  # (3, n)
    frames: np.ndarray  # sample indices of the movie (empty: none kept)
    frame_U: np.ndarray  # (frames, n)


def first_contact(force: np.ndarray) -> tuple[int, int, int] | None:
    """Sample indices of the first contact's start (first sample with a positive
    force), its peak force and its release (the first sample after the start with none
    again, or the last sample); None when the run has no contact."""
    on = np.flatnonzero(force > 1e-12 * max(float(np.max(force)), 0.0))
    if on.size == 0:
        return None
    start = int(on[0])
    off = np.flatnonzero(force[start:] <= 0)
    end = start + int(off[0]) if off.size else force.size - 1
    peak = start + int(np.argmax(force[start:end + 1]))
    return start, peak, end


def run_pictures(title: str, fields: BodyFields, problem: Any, traj: Any,
                 movie: bool = False) -> RunPictures | None:
    """The picture data of a run (None when it has no contact)."""
    area = float(np.sum(problem.contact.weights))
    force = -np.asarray(traj.stress, float) * area
    snaps = first_contact(force)
    if snaps is None:
        return None
    axis, level = max(fields.axis, 0), fields.level
    frames = (np.unique(np.linspace(0, traj.t.size - 1, min(MOVIE_FRAMES, traj.t.size))
                        .round().astype(int)) if movie else np.zeros(0, int))
    return RunPictures(title, fields, np.asarray(traj.t, float), force, axis, level,
                       snaps, np.asarray(traj.U[list(snaps)]), frames,
                       np.asarray(traj.U[frames]) if movie else np.zeros((0, 0)))


def _boundary_faces(fields: BodyFields, t: np.ndarray) -> np.ndarray:
    """(faces, 3) boundary triangles of the 3D cells t (quadrilateral faces split)."""
    if fields.cell_type == "tetra":
        local = [(0, 1, 2), (0, 1, 3), (0, 2, 3), (1, 2, 3)]
    else:  # VTK hexahedron faces
        local = [(0, 1, 2, 3), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6),
                 (3, 0, 4, 7)]
    faces = np.concatenate([t[:, list(f)] for f in local])
    key = np.sort(faces, axis=1)
    _, idx, counts = np.unique(key, axis=0, return_index=True, return_counts=True)
    outer = faces[idx[counts == 1]]
    if outer.shape[1] == 4:
        outer = np.concatenate([outer[:, [0, 1, 2]], outer[:, [0, 2, 3]]])
    return outer


def _triangles(fields: BodyFields) -> np.ndarray:
    t = fields.cells
    if fields.cell_type == "quad":
        return np.concatenate([t[:, [0, 1, 2]], t[:, [0, 2, 3]]])
    return t


def _bounds(pics: RunPictures, U: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The smallest and largest coordinates of the deformed body over the states U."""
    f = pics.fields
    x = f.points[None] + f.displacement(U)[:, :, :f.dim]
    return x.min(axis=(0, 1)), x.max(axis=(0, 1))


def _draw(ax: Any, pics: RunPictures, U: np.ndarray, vmax: float, title: str,
          bounds: tuple[np.ndarray, np.ndarray]) -> Any:
    """The deformed body on ax, coloured by the von Mises stress, in the box `bounds`
    (the obstacle shown in 2D); returns the mappable."""
    f = pics.fields
    x = f.points + f.displacement(U)[0][:, :f.dim]
    lo_all, hi_all = bounds
    pad_all = 0.08 * float(np.max(hi_all - lo_all))
    vm = f.von_mises(U)[0]
    if f.dim == 2:
        m = ax.tripcolor(x[:, 0], x[:, 1], _triangles(f), vm, shading="gouraud",
                         cmap="viridis", vmin=0.0, vmax=vmax)
        ax.triplot(x[:, 0], x[:, 1], _triangles(f), lw=0.2, color="k", alpha=0.3)
        lo = np.minimum(lo_all, pics.level) - pad_all
        hi = np.maximum(hi_all, pics.level) + pad_all
        other = 1 - pics.axis
        span = [lo[other], hi[other]]
        if pics.axis == 1:
            ax.plot(span, [pics.level] * 2, color="0.3", lw=2)
        else:
            ax.plot([pics.level] * 2, span, color="0.3", lw=2)
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        ax.set_aspect("equal")
    else:
        from matplotlib import cm, colors
        from mpl_toolkits.mplot3d.art3d import Poly3DCollection

        # a cut-away: the elements whose centre lies behind the body's middle plane
        # across the view (y <= the middle), so that the section shows the interior
        cut = pics.axis - 1 if pics.axis > 0 else 1
        centre = x[f.cells].mean(axis=1)[:, cut]
        keep = centre <= 0.5 * (lo_all[cut] + hi_all[cut])
        faces = _boundary_faces(f, f.cells[keep] if keep.any() else f.cells)
        norm = colors.Normalize(0.0, vmax)
        poly = Poly3DCollection(x[faces], facecolors=cm.viridis(norm(vm[faces].mean(axis=1))),
                                edgecolor=(0, 0, 0, 0.15), linewidths=0.2)
        ax.add_collection3d(poly)
        c, r = 0.5 * (lo_all + hi_all), 0.5 * float(np.max(hi_all - lo_all))
        for k, setter in enumerate((ax.set_xlim, ax.set_ylim, ax.set_zlim)):
            setter(c[k] - r, c[k] + r)
        ax.view_init(elev=-8, azim=90 if cut == 1 else 0, vertical_axis="xyz"[pics.axis])
        ax.set_box_aspect((1, 1, 1))
        ax.set_axis_off()
        m = cm.ScalarMappable(norm=norm, cmap="viridis")
    ax.set_title(title, fontsize=9)
    return m


def snapshot_figure(pics: RunPictures) -> Any:
    """Three panels: the deformed body at the first contact's start, peak force and
    release, one colour scale (von Mises stress)."""
    import matplotlib.pyplot as plt

    f = pics.fields
    vmax = float(np.max(f.von_mises(pics.snap_U))) or 1.0
    kw = {"projection": "3d"} if f.dim == 3 else {}
    fig, axes = plt.subplots(1, 3, figsize=(11, 4.2), subplot_kw=kw)
    m = None
    bounds = _bounds(pics, pics.snap_U)
    names = list(SNAPSHOT_NAMES)
    if pics.force[pics.snapshots[2]] > 0:  # the run ended in contact
        names[2] = "end of the run (in contact)"
    for j, (ax, k, name) in enumerate(zip(axes, pics.snapshots, names, strict=True)):
        m = _draw(ax, pics, pics.snap_U[j], vmax,
                  f"{name}\nt = {pics.t[k]:.4g}, force {pics.force[k] + 0.0:.3g}", bounds)
    fig.colorbar(m, ax=list(axes), shrink=0.8, label="von Mises stress")
    fig.suptitle(pics.title, fontsize=10)
    return fig


def write_movie(pics: RunPictures, path: str | Path, fps: int = 12) -> Path:
    """The run's frames (the body beside its contact force, a marker at the frame's
    time) as a GIF, or an MP4 when path ends in .mp4 (imageio with imageio-ffmpeg)."""
    import imageio.v2 as imageio
    import matplotlib.pyplot as plt

    f = pics.fields
    vmax = float(np.max(f.von_mises(pics.frame_U))) or 1.0
    bounds = _bounds(pics, pics.frame_U)
    images = []
    for i, k in enumerate(pics.frames):
        fig = plt.figure(figsize=(9, 3.8), dpi=80)
        ax = fig.add_subplot(1, 2, 1, **({"projection": "3d"} if f.dim == 3 else {}))
        m = _draw(ax, pics, pics.frame_U[i], vmax, f"t = {pics.t[k]:.4g}", bounds)
        fig.colorbar(m, ax=ax, shrink=0.8, label="von Mises")
        ax2 = fig.add_subplot(1, 2, 2)
        ax2.plot(pics.t, pics.force, lw=1)
        ax2.plot([pics.t[k]], [pics.force[k]], "o", color="C3")
        ax2.set_xlabel("t")
        ax2.set_ylabel("total contact force")
        fig.suptitle(pics.title, fontsize=9)
        fig.tight_layout()
        fig.canvas.draw()
        images.append(np.asarray(fig.canvas.buffer_rgba())[:, :, :3].copy())
        plt.close(fig)
    path = Path(path)
    if path.suffix == ".mp4":
        imageio.mimsave(path, images, fps=fps)
    else:
        imageio.mimsave(path, images, duration=1000.0 / fps, loop=0)
    return path


def movie_formats() -> Sequence[str]:
    """The movie formats this installation writes: gif with imageio, mp4 also with
    imageio-ffmpeg."""
    out = []
    try:
        import imageio  # noqa: F401
    except ImportError:
        return out
    out.append("gif")
    try:
        import imageio_ffmpeg  # noqa: F401
    except ImportError:
        return out
    out.append("mp4")
    return out


def scene_pictures(rows: Any) -> tuple[RunPictures, dict[str, Any]] | None:
    """The snapshots of a 2D/3D scene for a report (the study's index.html): one of its
    finished rows (a pandas DataFrame of one case) run again with its samples, the
    scene's `reference_scheme` when it has one, else the first, at the coarsest grid of
    the 'refine' group (or any); None when the scene gives no body, no row finished or
    the run has no contact. Returns the pictures and the run's (scheme, nx, dt, T)."""
    from contact_bench.api.registry import make_case
    from contact_bench.harness.runner import run_one
    from contact_bench.output.fields import body_fields

    ok = rows[rows["status"] == "ok"]
    if ok.empty:
        return None
    case = make_case(str(ok["case"].iloc[0]))
    if case.form != "sparse" or case.body(int(ok["nx"].min())) is None:
        return None
    if "group" in ok:
        refine = ok[ok["group"].astype(str).str.contains("refine")]
        ok = refine if not refine.empty else ok
    preferred = getattr(case, "reference_scheme", None)
    names = ok["scheme"].astype(str).str.split("[").str[0]
    if preferred is not None and (names == preferred).any():
        ok = ok[names == preferred]
    row = ok.sort_values(["nx", "dt"], ascending=[True, False]).iloc[0]
    nx, dt, T = int(row["nx"]), float(row["dt"]), float(row["T"])
    steps = max(1, int(round(T / dt)))
    run = run_one(case, str(row["scheme"]), nx=nx, dt=dt, T=T,
                  stride=max(1, steps // 400))
    if run.trajectory is None:
        return None
    try:
        fields = body_fields(case.body(nx), run.problem)
    except ValueError:
        return None
    pics = run_pictures(f"{case.spec} / {row['scheme']} (nx {nx}, dt {dt:g})", fields,
                        run.problem, run.trajectory)
    if pics is None:
        return None
    return pics, {"scheme": str(row["scheme"]), "nx": nx, "dt": dt, "T": T}
