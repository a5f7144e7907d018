"""Which triangles of a deformed mesh cover a point: the test of the keypoints and box
outlines that a fold may hide (:func:`glmls.batch.labels.mesh_keypoints`), through the boxes
of the mesh's tiles of 16 x 16 cells, then of the tiles' pieces of a row of cells, then of
the cells; and the chunk's meshes as the GPU gives them (:class:`MeshVertices`)."""

from __future__ import annotations

import numpy as np

from .embedding import cross

__all__ = [
    "COVER_BLOCK",
    "PAIRS_BLOCK",
    "MeshVertices",
    "boxes_per_mesh",
    "covered_earlier",
    "tile_boxes",
]


#: Cells a side of the tiles of a mesh, and in a piece of a row of cells: a folded mesh's
#: rows of cells curl over much of the image, and a point meets many rows but few tiles.
#: :func:`covered_earlier` tests a point against the tiles' boxes, then against those of
#: the pieces of the tiles whose box holds it, then gathers the vertices of the pieces
#: whose box holds it.
_TILE = 16


def boxes_per_mesh(vertices) -> int:
    """The tiles per mesh of ``vertices`` (N, rows, columns, 2), whose boxes
    :func:`covered_earlier` tests every point against first."""
    _, rows, columns, _ = vertices.shape
    return -(-(rows - 1) // _TILE) * -(-(columns - 1) // _TILE)


def tile_boxes(vertices, chosen: np.ndarray) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """The boxes of the tiles (:data:`_TILE` x :data:`_TILE` cells, fewer at the mesh's
    last row and column) of the meshes ``chosen``, and of the tiles' pieces of a row of
    cells: least x, least y, greatest x, greatest y, four (M, tiles) arrays (tile (i, j) at
    i * (tiles a row) + j) and four (M, rows of cells, tiles a row) arrays."""
    reduces = (np.minimum, np.minimum, np.maximum, np.maximum)
    extents = zip(_piece_extents(vertices, chosen), reduces, strict=True)
    pieces = [reduce(line[:, :-1], line[:, 1:]) for line, reduce in extents]
    starts = np.arange(0, pieces[0].shape[1], _TILE)
    tiles = [
        reduce.reduceat(piece, starts, axis=1).reshape(len(chosen), -1)
        for piece, reduce in zip(pieces, reduces, strict=True)
    ]
    return tiles, pieces


def covered_earlier(
    vertices,
    chosen: np.ndarray,
    boxes: tuple[list[np.ndarray], list[np.ndarray]],
    which: np.ndarray,
    points: np.ndarray,
    own: np.ndarray,
) -> np.ndarray:
    """(P,) bool: a triangle of deformed mesh ``chosen[which]`` (of ``vertices``, (N, rows,
    columns, 2), an array or :class:`MeshVertices`; ``boxes``: :func:`tile_boxes` of
    ``chosen``) before key ``own`` holds the point strictly inside (either orientation:
    folded triangles are drawn too). Every mesh's points at once: against the boxes of its
    tiles, then of the pieces of rows of the tiles whose box holds the point, then of the
    cells of the pieces whose box does, then the triangles of the cells whose box does: the
    pairs in blocks that gather at most :data:`COVER_BLOCK` values."""
    tiles, pieces = boxes
    index, tile = _near_tiles(tiles, which, points)
    hidden = np.zeros(len(points), bool)
    rows, across = pieces[0].shape[1:]
    block = max(1, COVER_BLOCK // (4 * _TILE))  # (point, tile) pairs: their rows' boxes
    piece_block = max(1, COVER_BLOCK // (2 * (_TILE + 1)))  # (point, piece): its vertices
    for start in range(0, len(index), block):
        pairs = slice(start, start + block)
        point, mesh = index[pairs], which[index[pairs]]
        tile_row, tile_col = np.divmod(tile[pairs], across)
        row = np.minimum(tile_row[:, None] * _TILE + np.arange(_TILE), rows - 1)  # (T, tile)
        qx, qy = points[point, :1], points[point, 1:]
        lx, ly, hx, hy = (box[mesh[:, None], row, tile_col[:, None]] for box in pieces)
        real = tile_row[:, None] * _TILE + np.arange(_TILE) < rows  # a last tile's fewer rows
        pair, k = np.nonzero((lx <= qx) & (qx <= hx) & (ly <= qy) & (qy <= hy) & real)
        slot, held = row[pair, k] * across + tile_col[pair], point[pair]
        for part in range(0, len(pair), piece_block):
            chunk = slice(part, part + piece_block)
            _cover_pairs(vertices, chosen, which, points, own, held[chunk], slot[chunk], hidden)
    return hidden


def _cover_pairs(vertices, chosen, which, points, own, index, slot, hidden) -> None:
    """:func:`covered_earlier` for the pairs (``index``: point, ``slot``: piece k of row r
    as r * (pieces a row) + k) whose piece's box holds the point, into ``hidden``."""
    columns = vertices.shape[2] - 1
    row, piece = np.divmod(slot, -(-columns // _TILE))
    image = chosen[which[index]][:, None]
    first = piece[:, None] * _TILE
    at = np.minimum(first + np.arange(_TILE + 1), columns)  # (T, tile + 1) vertices
    top = vertices[image, row[:, None], at]
    bottom = vertices[image, row[:, None] + 1, at]  # (T, tile + 1, 2)
    corners = [top[:, :-1], top[:, 1:], bottom[:, 1:], bottom[:, :-1]]  # 00, 10, 11, 01
    qx, qy = points[index, :1], points[index, 1:]
    lx, ly, hx, hy = (
        reduce(
            reduce(corners[0][..., k], corners[1][..., k]),
            reduce(corners[2][..., k], corners[3][..., k]),
        )
        for reduce, k in ((np.minimum, 0), (np.minimum, 1), (np.maximum, 0), (np.maximum, 1))
    )  # (T, tile): the boxes of that piece's cells
    real = first + np.arange(_TILE) < columns  # the last piece's cells past the row's end
    pair, cell = np.nonzero((lx <= qx) & (qx <= hx) & (ly <= qy) & (qy <= hy) & real)
    if not len(pair):
        return
    point = index[pair]
    q = points[point]
    key = (row[pair] * columns + first[pair, 0] + cell) * 2
    for triangle, (p0, p1, p2) in enumerate(((0, 1, 2), (0, 2, 3))):
        earlier = key + triangle < own[point]
        x0, x1, x2 = (corners[k][pair, cell] for k in (p0, p1, p2))
        area = cross(x1 - x0, x2 - x0)
        sign = np.sign(area)
        tiny = 1e-9 * np.abs(area)
        strictly = (sign != 0) & earlier
        for u, v in ((x0, x1), (x1, x2), (x2, x0)):
            strictly &= cross(v - u, q - u) * sign > tiny
        hidden[point[strictly]] = True


#: Vertices (pairs of a point and a tile whose box holds it, times the vertices of a tile)
#: that :func:`covered_earlier` gathers in one block.
COVER_BLOCK = 1 << 21
#: Points times tiles in one block of points of :func:`covered_earlier`'s callers: the most
#: pairs (point, tile) the block can make.
PAIRS_BLOCK = 1 << 22

#: Values (points times tiles) that :func:`_near_tiles` compares in one block.
_NEAR_BLOCK = 1 << 20


def _near_tiles(boxes: list[np.ndarray], which: np.ndarray, points: np.ndarray):
    """The pairs (point, tile) whose tile's box (``boxes``: least x, least y, greatest x,
    greatest y of each mesh's tiles, four (M, tiles) arrays) holds the point, each point
    against its own mesh ``which``: two (T,) index arrays. In blocks of points, so that
    neither many points nor many meshes make a large array (no mesh is padded to the most
    points of any)."""
    tiles = boxes[0].shape[1]
    block = max(1, _NEAR_BLOCK // max(tiles, 1))
    found = []
    for start in range(0, len(points), block):
        mine = which[start : start + block]
        if len(mine) and np.all(mine == mine[0]):  # one mesh's points: its boxes broadcast
            mine = mine[:1]
        lx, ly, hx, hy = (box[mine] for box in boxes)  # (B, tiles) or (1, tiles)
        qx, qy = points[start : start + block, :1], points[start : start + block, 1:]
        index, tile = np.nonzero((lx <= qx) & (qx <= hx) & (ly <= qy) & (qy <= hy))
        found.append((index + start, tile))
    if not found:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    return np.concatenate([f[0] for f in found]), np.concatenate([f[1] for f in found])


def _piece_extents(vertices, chosen: np.ndarray) -> list[np.ndarray]:
    """Least x, least y, greatest x, greatest y of the vertices of each piece of each row of
    vertices of the meshes ``chosen`` (:data:`_TILE` + 1 vertices, the ends of its cells):
    four (M, rows, pieces) arrays (:meth:`MeshVertices.piece_extents` where it is one)."""
    if isinstance(vertices, MeshVertices):
        return vertices.piece_extents(chosen, _TILE)
    return _pieces(np.asarray(vertices)[chosen], _TILE)


def _pieces(values: np.ndarray, piece: int) -> list[np.ndarray]:
    """The extents of :func:`_piece_extents` of ``values`` (M, rows, columns, 2)."""
    columns = values.shape[2] - 1
    starts = np.arange(0, max(columns, 1), piece)
    ends = np.minimum(starts + piece, columns)
    out = []
    for reduce in (np.minimum, np.maximum):
        for axis in (0, 1):
            line = values[..., axis]
            # the vertices first .. next first - 1 (the last piece: to the row's end), then
            # the piece's last vertex, the next piece's first
            out.append(reduce(reduce.reduceat(line, starts, axis=2), line[:, :, ends]))
    return out


class MeshVertices:
    """A chunk's deformed meshes (N, rows, columns, 2) in pixels, float64, as
    :meth:`glmls.batch.gpu.BatchQuads.vertices` reads them: float32 f at the lattice
    (scaled), converted (``scaled * scale + centre``, as a whole array would be) only where
    indexed: ``v[k]`` image k's (rows, columns, 2), ``v[images, rows, columns]`` those
    vertices' (P, 2)."""

    ndim = 4

    def __init__(self, scaled: np.ndarray, scales: np.ndarray, centers: np.ndarray) -> None:
        self._scaled = scaled  # (N, rows, columns, 2) float32
        self._scales = scales
        self._centers = centers

    def __len__(self) -> int:
        return len(self._scaled)

    @property
    def shape(self) -> tuple[int, ...]:
        return self._scaled.shape

    def piece_extents(self, images: np.ndarray, piece: int) -> list[np.ndarray]:
        """Least x, least y, greatest x, greatest y of the pieces of ``piece`` cells of each
        row of vertices of ``images`` (:func:`_piece_extents`): four (M, rows, pieces)
        arrays, reduced in float32 and then converted (the conversion is increasing, so the
        extremes are those of the converted vertices, bit for bit)."""
        scale = self._scales[images][:, None, None]
        centre = self._centers[images]
        extents = _pieces(self._scaled[images], piece)
        return [
            extreme.astype(np.float64) * scale + centre[:, k % 2, None, None]
            for k, extreme in enumerate(extents)
        ]

    def flat_points(self, at: np.ndarray, images: np.ndarray) -> np.ndarray:
        """The vertices at flat indices ``at`` (k, P) into (N * rows * columns) of the
        meshes ``images`` (P,) that hold them: (k, 2, P), x and y apart, converted as
        :meth:`__getitem__` converts them."""
        # np.take: numpy's fancy indexing runs several times slower; from the flat array
        # (x and y interleaved), as np.take copies a strided one whole before it gathers
        scaled = self._scaled.reshape(-1)
        twice = 2 * at
        scale = np.take(self._scales, images)
        out = np.empty((len(at), 2, len(images)))
        for axis in (0, 1):
            values = np.take(scaled, twice + axis).astype(np.float64)
            values *= scale
            values += np.take(self._centers[:, axis], images)
            out[:, axis] = values
        return out

    def __getitem__(self, key):
        image = key[0] if isinstance(key, tuple) else key
        scaled = self._scaled[key].astype(np.float64)
        extra = scaled.ndim - np.ndim(image) - 1  # the axes between the images' and x, y
        scale = np.reshape(self._scales[image], np.shape(image) + (1,) * (extra + 1))
        centre = np.reshape(self._centers[image], np.shape(image) + (1,) * extra + (2,))
        return scaled * scale + centre
