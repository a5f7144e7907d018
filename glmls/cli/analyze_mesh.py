"""``glmls analyze`` on a mesh or point cloud (a PLY, OBJ or STL input) with 3D handles: the
3D analysis at the mesh's vertices, on the GPU (:class:`glmls.MLS` of (N, 3) handles),
written as ``report.json`` (the statistics), ``vertices.npz`` (the values at every vertex
and the folds of every face, :data:`VERTEX_ARRAYS`) and the deformed mesh ``deformed.ply``.

- ``error_field``: the MLS error E_MLS (eq. 7) at every vertex, sum_i |p_i M_v + T_v - q_i|^2,
  and its statistics (eqs. 8, 9, the median and the trimmed mean);
- ``tetrahedra``: the reference tetrahedra's distance and angular errors
  (:func:`glmls.analysis.tetrahedron_errors`; the reference points of ``--reference``, else
  the distinct source handles);
- ``jacobians``: det J and the ratio of J's largest to smallest singular value at every
  vertex, and the vertices and faces that fold (:meth:`glmls.MLS.deform`), with the count
  of the input's faces of zero area (``degenerate_faces``: a repeated vertex, three
  vertices on a line), which have no orientation to keep and count among the folded faces.
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import numpy as np

from ..analysis.stats import error_stats
from ..analysis.tetrahedra import tetrahedron_errors
from ..analysis.volume_field import fit_residuals
from ..core.config import MLSConfig
from ..core.handles3 import as_points3
from ..files.atomic import atomic_write
from ..files.json_out import write_json
from ..files.meshes import MESH_SUFFIXES, read_mesh_and_unkept, unwritten, write_mesh
from ..files.volumes import volume_suffix
from ..mls import MLS
from .analyze_volume import check_reference_3d, read_reference_3d
from .inputs import figure, keep_inputs, reported_warnings, say
from .options import UsageError, config_from_args
from .progress import Ticker
from .warp3d import check_world, read_3d_handles, refuse_image_options, refuse_sampling_options

__all__ = ["VERTEX_ARRAYS", "is_mesh_input", "run_mesh"]

#: The arrays of ``vertices.npz``: per vertex (V,) the MLS error (eq. 7, float64), det J
#: (float32, as :meth:`glmls.MLS.deform` gives it), the singular value ratio (float64; NaN
#: where J is singular) and the fold flags (bool); per face (F,) the fold flags (bool).
VERTEX_ARRAYS = ("error_field", "det_j", "ratio", "vertex_folds", "face_folds")


def is_mesh_input(args: argparse.Namespace) -> bool:
    """Whether ``analyze``'s input is a mesh (by its suffix: PLY, OBJ, STL)."""
    return (
        not args.example and args.input is not None and volume_suffix(args.input) in MESH_SUFFIXES
    )


def _check_radius(config: MLSConfig) -> MLSConfig:
    if config.uses_radius and config.radius is None:
        raise UsageError(
            f"--weight {config.weight} needs --radius R for a mesh (in the units of its "
            "coordinates): a mesh has no image or volume diagonal to default to"
        )
    return config


def _deformation(src: np.ndarray, dst: np.ndarray, config: MLSConfig) -> MLS:
    try:
        return MLS.from_config(src, dst, config)
    except (TypeError, ValueError) as error:
        raise UsageError(f"handles: {error}") from None


def _distinct(points: np.ndarray) -> np.ndarray:
    _, first = np.unique(points, axis=0, return_index=True)
    return points[np.sort(first)]


#: What a mesh's analysis writes into ``--out``.
_OUTPUTS = ("report.json", "vertices.npz", "deformed.ply")


def _ratios(jacobian: np.ndarray, det: np.ndarray) -> np.ndarray:
    """The largest over the smallest singular value of each J (K, 3, 3); NaN where J is
    singular (to float32's rounding: ``det`` 0, as :meth:`glmls.MLS.deform` gives it)."""
    singular = np.linalg.svd(jacobian, compute_uv=False)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where((singular[:, 2] > 0) & (det != 0), singular[:, 0] / singular[:, 2], np.nan)


def _degenerate_faces(vertices: np.ndarray, faces: np.ndarray) -> int:
    """The number of faces of zero area (exactly, in float64) among ``faces`` (F, 3)."""
    if len(faces) == 0:
        return 0
    corners = np.asarray(vertices, dtype=np.float64)[np.asarray(faces)]
    normal = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    return int((~normal.any(axis=1)).sum())


def run_mesh(args: argparse.Namespace) -> int:
    """``glmls analyze MESH --handles H3 --out DIR``."""
    if args.handles is None:
        raise UsageError("missing --handles (a file of 3D handles for a mesh)")
    if args.spacing is not None:
        raise UsageError(f"--spacing: for volumes, not for a mesh ({args.input})")
    check_world(args)
    refuse_image_options(args, "mesh")
    pictures = (("--analysis-grid", args.analysis_grid, 1), ("--cmap", args.cmap, "viridis"))
    refuse_sampling_options(args, pictures)
    config = _check_radius(config_from_args(args))
    mesh, unkept = read_mesh_and_unkept(args.input)
    try:  # vertices beyond the GPU's coordinate range: refused before any work, as by warp
        as_points3(mesh.vertices, "mesh vertices")
    except ValueError as error:
        raise UsageError(f"{args.input}: {error}") from None
    src, dst = read_3d_handles(args, "mesh")
    reference, tetrahedra = read_reference_3d(args.reference) if args.reference else (None, None)
    check_reference_3d(args.reference, reference, tetrahedra)
    if reference is None:
        say(args, "analyze: no --reference given: the source handles are the reference points")
    keep_inputs(args, [Path(args.out) / name for name in _OUTPUTS])
    ticker = Ticker("analyze", quiet=args.quiet)
    with _deformation(src, dst, config) as m, ticker as tick, reported_warnings("analyze"):
        tick.stage("deform")
        deformed = m.deform(mesh)
        tick.stage("error field")
        matrix, translation = m.matrices(mesh.vertices)
        field = fit_residuals(src, dst, matrix, translation)
        tick.stage("tetrahedra")
        try:
            points = _distinct(src) if reference is None else reference
            found = tetrahedron_errors(m, points, tetrahedra=tetrahedra, angle=args.angle).stats()
        except ValueError as error:
            if reference is not None:
                raise UsageError(f"{args.reference}: {error}") from None
            found = {"skipped": f"the source handles as reference points: {error}"}
    vertex_folds, face_folds = int(deformed.vertex_folds.sum()), int(deformed.face_folds.sum())
    degenerate = _degenerate_faces(mesh.vertices, mesh.faces)
    ratios = _ratios(deformed.jacobian, deformed.det_j)
    summary = {
        "mesh": {"vertices": len(mesh.vertices), "faces": len(mesh.faces)},
        "configuration": dataclasses.asdict(config)
        | {"handles": len(src), "src": src.tolist(), "dst": dst.tolist()},
        "analysis": {
            "angle": args.angle,
            "reference_points": "handles" if reference is None else "given",
        },
        "error_field": error_stats(field) | {"unit": "(handle units)^2"},
        "tetrahedra": found,
        "jacobians": {
            "vertices": len(mesh.vertices),
            "det": error_stats(deformed.det_j),
            "ratio": error_stats(ratios),
            "vertex_folds": vertex_folds,
            "face_folds": face_folds,
            "degenerate_faces": degenerate,
        },
        "input": str(args.input),
    }
    out = Path(args.out)
    paths = [out / name for name in _OUTPUTS]
    write_json(paths[0], summary)
    values = (field, deformed.det_j, ratios, deformed.vertex_folds, deformed.face_folds)
    with atomic_write(paths[1]) as tmp, open(tmp, "wb") as file:
        np.savez(file, **dict(zip(VERTEX_ARRAYS, values, strict=True)))
    write_mesh(
        paths[2],
        deformed.vertices,
        faces=mesh.faces,
        colors=mesh.colors,
        uv=mesh.uv,
        face_uv=mesh.face_uv,
        # the input's own normals carried by J^-T, as glmls warp writes them: a shaded mesh
        # keeps its shading, and a file gains no normals its input did not have
        normals=None if mesh.normals is None else deformed.normals,
    )
    unkept = (*unwritten(paths[2], mesh), *unkept)
    if unkept:  # as glmls warp names them
        say(args, f"analyze: {paths[2]} does not carry the input's {', '.join(unkept)}")
    for path in paths:
        print(path)
    field_stats, det = summary["error_field"], summary["jacobians"]["det"]
    say(
        args,
        f"analyze: E_MLS at {len(mesh.vertices)} vertices median "
        f"{figure(field_stats['median'])}, trimmed mean {figure(field_stats['trimmed_mean'])}, "
        f"mean {figure(field_stats['mean'])} (std {figure(field_stats['std'])}) "
        f"{field_stats['unit']}",
    )
    if "angle" in found:
        say(
            args,
            f"analyze: {found['tetrahedra']} tetrahedra ({found['slivers']} slivers left out), "
            f"angular error ({args.angle}) median {figure(found['angle']['median'])}, "
            f"mean {figure(found['angle']['mean'])}; {found['inverted']} inverted",
        )
    else:
        say(args, f"analyze: no tetrahedra: {found['skipped']}")
    say(
        args,
        f"analyze: det J median {figure(det['median'])}, min {figure(det['min'])}; folded: "
        f"{vertex_folds} vertices, {face_folds} faces"
        + (f" ({degenerate} of zero area in the input)" if degenerate else ""),
    )
    return 0
