"""Where on the whole map could this scan have been taken? Candidates for global relocalisation.

A kidnapped or lost robot cannot trust its pose, so the filter is re-seeded from the scan alone.
Uniform particles do not reach: on a 30 x 50 m warehouse, 20 000 random poses leave a pose
within 10 cm and 5 degrees of the truth with odds of about one in three. Instead every pose of
a lattice over the free space (``stride_m`` apart, ``heading_step_deg`` between headings) is
scored by the scan against a coarse, widened likelihood field, and the best ``candidates`` seed
the particle filter, which the fine field and the next scans (the robot turning on the spot)
narrow to one pose, or leave spread over several when the site repeats itself (then the
filter's spread says so and nobody believes it).

The coarse field: the map's distance field taken at its least over blocks of ``cell_m`` (a
block is as near a wall as its nearest cell), scored as the beam model with ``sigma_m`` wide
enough to forgive the lattice's half-step in position and heading at a beam's range. A
lattice pose sits at a coarse cell's centre, so a beam's end point falls ``round(v / cell)``
cells from it whatever the pose: one offset per beam and heading, and the score of every
position at that heading is a single gather from a bordered table.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from behaviours.nav.localisation.likelihood_field import DistanceGrid

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class SearchConfig:
    """The lattice and the coarse field of a global search."""

    cell_m: float = 0.1
    """The coarse field's cell (the map's cells are merged up to this)."""
    stride_m: float = 0.2
    """Candidate positions are this far apart (a whole number of coarse cells)."""
    heading_step_deg: float = 5.0
    beams: int = 48
    """Scan beams scored (evenly picked from those with a return)."""
    sigma_m: float = 0.3
    """Width of the coarse field's beam model."""
    max_range_m: float = 12.0
    candidates: int = 1500
    """Lattice poses kept to seed the filter."""
    clearance_m: float = 0.15
    """A candidate position is at least this far from every obstacle (a robot stands there)."""


class GlobalSearch:
    """The lattice and coarse field of one map (built once, searched per relocalisation)."""

    def __init__(self, grid: DistanceGrid, config: SearchConfig | None = None) -> None:
        self.config = c = config or SearchConfig()
        res = grid.resolution_m
        self.block = max(1, round(c.cell_m / res))
        self.cell_m = self.block * res
        self.origin = (grid.origin_x_m, grid.origin_y_m)
        rows, cols = grid.shape
        b = self.block
        crow, ccol = math.ceil(rows / b), math.ceil(cols / b)
        big = float(c.max_range_m)
        dist = np.full((crow * b, ccol * b), big, dtype=np.float32)
        dist[:rows, :cols] = grid.distance_m
        coarse = dist.reshape(crow, b, ccol, b).min(axis=(1, 3))
        # Score: log of the beam model, z_rand keeping a beam that hits nothing from vetoing.
        score = np.log(np.exp(-(coarse * coarse) / (2 * c.sigma_m ** 2)) + 0.05).astype(
            np.float32)
        outside = float(np.log(0.05))
        self.pad = math.ceil(c.max_range_m / self.cell_m) + 2
        table = np.pad(score, self.pad, constant_values=outside)
        self.table = table.ravel()
        self.table_cols = int(table.shape[1])
        # Lattice positions: coarse cells every stride, whose centre stands free.
        step = max(1, round(c.stride_m / self.cell_m))
        free = grid.free_cells() & (grid.distance_m >= c.clearance_m)
        ci, cj = np.meshgrid(np.arange(0, crow, step), np.arange(0, ccol, step), indexing="ij")
        centre_r = np.minimum(((ci + 0.5) * b).astype(np.intp), rows - 1)
        centre_c = np.minimum(((cj + 0.5) * b).astype(np.intp), cols - 1)
        ok = free[centre_r, centre_c]
        self.cells_r = ci[ok].astype(np.int32)
        self.cells_c = cj[ok].astype(np.int32)
        self.flat = ((self.cells_r + self.pad) * self.table_cols
                     + self.cells_c + self.pad).astype(np.int32)
        self.headings = np.radians(np.arange(-180.0, 180.0, c.heading_step_deg))
        self.stride_cells = step

    @property
    def positions(self) -> int:
        return int(self.flat.shape[0])

    def centres(self) -> FloatArray:
        """The lattice positions (x, y) in the map frame."""
        x = self.origin[0] + (self.cells_c + 0.5) * self.cell_m
        y = self.origin[1] + (self.cells_r + 0.5) * self.cell_m
        return np.column_stack((x, y))

    def pick_beams(self, beams_xy: FloatArray) -> FloatArray:
        """Up to ``beams`` of the scan's end points (robot frame), evenly spread, in range."""
        pts = np.asarray(beams_xy, dtype=np.float64).reshape(-1, 2)
        pts = pts[np.hypot(pts[:, 0], pts[:, 1]) < self.config.max_range_m]
        if pts.shape[0] > self.config.beams:
            pts = pts[np.linspace(0, pts.shape[0] - 1, self.config.beams).astype(np.intp)]
        return pts

    def scores(self, beams_xy: FloatArray) -> npt.NDArray[np.float32]:
        """Every lattice pose's score: (headings, positions), the sum over the beams."""
        pts = self.pick_beams(beams_xy)
        out = np.zeros((self.headings.shape[0], self.positions), dtype=np.float32)
        if pts.shape[0] == 0 or self.positions == 0:
            return out
        for k, theta in enumerate(self.headings):
            c, s = math.cos(theta), math.sin(theta)
            dx = (c * pts[:, 0] - s * pts[:, 1]) / self.cell_m
            dy = (s * pts[:, 0] + c * pts[:, 1]) / self.cell_m
            # From a cell's centre, an end point v lands floor(0.5 + v) cells away.
            offset = (np.floor(0.5 + dy).astype(np.int32) * self.table_cols
                      + np.floor(0.5 + dx).astype(np.int32))
            index = self.flat[:, None] + offset[None, :]
            out[k] = self.table.take(index).sum(axis=1)
        return out

    def candidates(self, beams_xy: FloatArray, rng: np.random.Generator,
                   per_candidate: int = 4) -> tuple[FloatArray, float]:
        """Particles round the best lattice poses (each jittered within its lattice cell and
        heading step), and the best score per beam (how well the scan fits anywhere)."""
        scores = self.scores(beams_xy)
        flat = scores.ravel()
        keep = min(self.config.candidates, flat.shape[0])
        if keep == 0:
            return np.zeros((0, 3)), -math.inf
        best = np.argpartition(-flat, keep - 1)[:keep]
        best = best[np.argsort(-flat[best], kind="stable")]
        k, p = np.unravel_index(best, scores.shape)
        centres = self.centres()[p]
        theta = self.headings[k]
        n = keep * per_candidate
        jitter = rng.random((n, 3)) - 0.5
        half = self.stride_cells * self.cell_m
        poses = np.column_stack((
            np.repeat(centres[:, 0], per_candidate) + jitter[:, 0] * half,
            np.repeat(centres[:, 1], per_candidate) + jitter[:, 1] * half,
            np.repeat(theta, per_candidate)
            + jitter[:, 2] * math.radians(self.config.heading_step_deg)))
        beams = max(1, self.pick_beams(beams_xy).shape[0])
        return poses, float(flat[best[0]]) / beams
