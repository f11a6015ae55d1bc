"""Triangle meshes of the FT4 cell for LIGGGHTS, written as ASCII STL, and a checker for them.

The geometry follows the numba_dem backend exactly (see its ``geometry.py``); the lateral wall is
not a mesh but LIGGGHTS' analytic cylinder (see ``script.py``):

* base: the plane z = 0, a disc slightly wider than the vessel;
* ribs (optional): ``base_ribs`` vertical radial plates of height ``rib_height`` at angles
  2πk/n, from the head's hub radius out to the vessel wall (ribs meeting at the axis would wedge a
  particle among all their edges at once);
* head: in its own frame, a disc of radius ``head_radius`` at z = 0 (its lower face is the head's
  height) with ``blade_count`` thin radial blades hanging below it, from ``hub_radius`` to
  ``head_radius``, down to z = −``blade_height``; blade k lies at angle 2πk/n at rotation 0.

Thin plates (blades, ribs) are single two-sided triangles pairs, as LIGGGHTS meshes are two-sided.
The disc's fan spokes are placed between blades so that no blade edge coincides with a disc edge
(an edge shared by three triangles is not a valid surface mesh).
"""

from __future__ import annotations

import math
from collections import Counter
from pathlib import Path

import numpy as np
from calibrax.core.sheartest.facets import radial_plate

__all__ = ["Mesh", "base_mesh", "ribs_mesh", "head_mesh", "write_stl", "read_stl", "check_stl",
           "MeshError"]

Mesh = np.ndarray  # triangles, shape (n, 3, 3), m


class MeshError(ValueError):
    """A mesh is not a valid triangle surface."""


def _fan_disc(radius: float, z: float, nseg: int, phase: float) -> np.ndarray:
    ang = phase + 2.0 * math.pi * np.arange(nseg + 1) / nseg
    ang[-1] = ang[0]
    rim = np.stack([radius * np.cos(ang), radius * np.sin(ang), np.full(ang.size, z)], axis=1)
    centre = np.array([0.0, 0.0, z])
    tris = [np.stack([centre, rim[k], rim[k + 1]]) for k in range(nseg)]
    return np.asarray(tris)


def segments_for(radius: float, particle_radius: float) -> int:
    """Polygon segments so that the chord sag stays below 1 % of a particle radius (≥ 48)."""
    # sag = r (1 − cos(π/n)) ≈ r π² / (2 n²)
    n = math.ceil(math.pi * math.sqrt(radius / (2.0 * 0.01 * particle_radius)))
    return int(max(48, min(n, 720)))


def base_mesh(vessel_radius: float, particle_radius: float) -> Mesh:
    """The base plane z = 0 (a disc 5 % wider than the vessel)."""
    return _fan_disc(1.05 * vessel_radius, 0.0, segments_for(vessel_radius, particle_radius), 0.0)


def ribs_mesh(inner_radius: float, vessel_radius: float, count: int, height: float) -> Mesh:
    """``count`` radial ribs of height ``height`` on the base, from ``inner_radius`` (the head's hub
    radius, as numba_dem: ribs meeting at the axis wedge a particle among all their edges at once)
    to the wall."""
    return np.concatenate([radial_plate(2.0 * math.pi * k / count, inner_radius, vessel_radius, 0.0, height)
                           for k in range(count)])


def head_mesh(head_radius: float, hub_radius: float, blade_count: int, blade_height: float,
              particle_radius: float) -> Mesh:
    """The bladed head in its own frame: disc at z = 0, blades below it (see module docstring)."""
    n = segments_for(head_radius, particle_radius)
    n = blade_count * max(1, math.ceil(n / blade_count))  # spokes evenly between the blades
    disc = _fan_disc(head_radius, 0.0, n, math.pi / n)
    blades = [radial_plate(2.0 * math.pi * k / blade_count, hub_radius, head_radius, -blade_height, 0.0)
              for k in range(blade_count)]
    return np.concatenate([disc] + blades)


# ----------------------------------------------------------------------------- STL
def _fmt(x: float) -> str:
    x = float(x)
    if not math.isfinite(x):
        raise MeshError(f"non-finite coordinate {x!r}")
    return format(x, ".12e")


def write_stl(path: Path, triangles: Mesh, name: str = "calibrax") -> Path:
    """Write ``triangles`` (n, 3, 3) as an ASCII STL solid; returns the path."""
    tri = np.asarray(triangles, dtype=float)
    if tri.ndim != 3 or tri.shape[1:] != (3, 3):
        raise MeshError(f"triangles must have shape (n, 3, 3), got {tri.shape}")
    if not name.isidentifier():
        raise MeshError(f"solid name must be an identifier, got {name!r}")
    lines = [f"solid {name}"]
    for t in tri:
        nrm = np.cross(t[1] - t[0], t[2] - t[0])
        length = float(np.linalg.norm(nrm))
        nrm = nrm / length if length > 0 else nrm
        lines.append("  facet normal " + " ".join(_fmt(c) for c in nrm))
        lines.append("    outer loop")
        for v in t:
            lines.append("      vertex " + " ".join(_fmt(c) for c in v))
        lines.append("    endloop")
        lines.append("  endfacet")
    lines.append(f"endsolid {name}")
    path = Path(path)
    path.write_text("\n".join(lines) + "\n", encoding="ascii")
    return path


def read_stl(path: Path) -> Mesh:
    """Read an ASCII STL file into an array (n, 3, 3); raise :class:`MeshError` if malformed."""
    text = Path(path).read_text(encoding="ascii")
    tokens = text.split()
    if not tokens or tokens[0] != "solid":
        raise MeshError(f"{path}: not an ASCII STL file (no 'solid')")
    if "endsolid" not in tokens:
        raise MeshError(f"{path}: no 'endsolid'")
    verts: list[list[float]] = []
    facets = 0
    i = 0
    while i < len(tokens):
        tok = tokens[i]
        if tok == "facet":
            facets += 1
        if tok == "vertex":
            try:
                verts.append([float(tokens[i + 1]), float(tokens[i + 2]), float(tokens[i + 3])])
            except (IndexError, ValueError) as exc:
                raise MeshError(f"{path}: malformed vertex near token {i}") from exc
            i += 4
            continue
        i += 1
    if len(verts) != 3 * facets:
        raise MeshError(f"{path}: {facets} facets but {len(verts)} vertices")
    return np.asarray(verts, dtype=float).reshape(-1, 3, 3)


def check_stl(path: Path, tol: float = 1e-12) -> dict[str, float]:
    """Check an ASCII STL surface: parsable, at least one facet, finite coordinates, no degenerate
    (zero-area) triangle, no duplicate triangle, and no edge shared by more than two triangles.

    Vertices closer than ``tol`` × the mesh size are merged before the edge count.

    Returns:
        dict with ``triangles``, ``edges``, ``boundary_edges`` (edges of one triangle),
        ``min_area`` (m²).

    Raises:
        MeshError: naming the first problem found.
    """
    tri = read_stl(path)
    if tri.shape[0] == 0:
        raise MeshError(f"{path}: no facets")
    if not np.all(np.isfinite(tri)):
        raise MeshError(f"{path}: non-finite coordinates")
    size = float(np.max(np.abs(tri))) or 1.0
    areas = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    if np.any(areas <= (tol * size) ** 2 * 1e3):
        k = int(np.argmin(areas))
        raise MeshError(f"{path}: triangle {k} is degenerate (area {areas[k]:.3e} m²)")
    keys = np.round(tri / (tol * size * 1e3)).astype(np.int64)
    vid: dict[tuple[int, int, int], int] = {}
    tri_ids = []
    for t in keys:
        ids = []
        for v in t:
            key = (int(v[0]), int(v[1]), int(v[2]))
            ids.append(vid.setdefault(key, len(vid)))
        if len(set(ids)) < 3:
            raise MeshError(f"{path}: a triangle has two coincident vertices")
        tri_ids.append(tuple(ids))
    seen = Counter(tuple(sorted(t)) for t in tri_ids)
    dup = [t for t, c in seen.items() if c > 1]
    if dup:
        raise MeshError(f"{path}: {len(dup)} duplicate triangle(s)")
    edges: Counter = Counter()
    for a, b, c in tri_ids:
        for e in ((a, b), (b, c), (c, a)):
            edges[tuple(sorted(e))] += 1
    bad = [e for e, c in edges.items() if c > 2]
    if bad:
        raise MeshError(f"{path}: {len(bad)} edge(s) shared by more than two triangles (first: vertex ids {bad[0]})")
    return {"triangles": float(tri.shape[0]), "edges": float(len(edges)),
            "boundary_edges": float(sum(1 for c in edges.values() if c == 1)), "min_area": float(np.min(areas))}
