"""Block-structured normal equations of the bundle: Schur complement on the object points.

Each object point is a 3x3 block ``A_p``.  Every observation ``k`` (point p,
image i) has a camera block of ``L = q + 6`` columns: the ``q`` interior
parameters of its camera and the 6 exterior parameters of its image, and its
coupling ``B_k = Jp_k^T Jc_k`` (3xL).  Since ``B_p = sum_k B_k`` (scattered into
the camera columns), the reduced camera matrix

    S = C - sum_p B_p^T A_p^-1 B_p = C - sum_p sum_{k,l in p} B_k^T A_p^-1 B_l

is a sum over the pairs of observations of each point, and every pair of images
(i, j) receives one dense LxL block.  The pairs are sorted by image pair once
per network (:class:`SchurLayout`); each linearisation then computes one BLAS
product per image pair, ``[B_k]^T [A^-1 B_l]`` over all the points the two
images share (Triggs et al. 2000, "Bundle adjustment - a modern synthesis",
section 6, the reduced camera system).  The posterior covariance of every
point and the redundancy number of every observation use the same image-pair
segments with the LxL blocks of ``S^-1`` (one gather per image pair).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["PointCameraSystem", "SchurLayout"]


def _bmm(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Batched (k,r,s) @ (k,s,t) for small blocks (stacked matmul: 2-4x einsum here)."""
    return np.matmul(a, b)


def _sum_by(index: np.ndarray, values: np.ndarray, n: int) -> np.ndarray:
    """Sum the rows of ``values`` (k, ...) into ``n`` bins given by ``index`` (k,)."""
    flat = values.reshape(len(index), -1)
    out = np.empty((n, flat.shape[1]))
    for j in range(flat.shape[1]):
        out[:, j] = np.bincount(index, weights=flat[:, j], minlength=n)
    return out.reshape((n,) + values.shape[1:])


@dataclass
class SchurLayout:
    """Index structure of a network, fixed over the iterations.

    Attributes
    ----------
    nc
        Number of free camera parameters (the dummy column ``nc`` takes the fixed ones).
    union
        Interior parameters (indices of :data:`~pyheracles.bundle.camera.IO_NAMES`)
        free for at least one camera; ``L = len(union) + 6``.
    img_cols
        (n_img, L) camera columns of every image (interior of its camera, then
        exterior), fixed parameters mapped to ``nc``.
    img_order, img_bounds
        Observations sorted by image, and the slice of each image.
    pair_a, pair_b, pair_bounds, pair_img
        Observation pairs (a, b) of the same point, image(a) < image(b), sorted by
        image pair; ``pair_bounds`` the slice of each image pair, ``pair_img``
        (n_seg, 2) the image pair.
    """

    nc: int
    n_points: int
    union: np.ndarray
    obs_point: np.ndarray
    obs_image: np.ndarray
    obs_cols: np.ndarray  # (m,L) padded camera columns of every observation
    img_cols: np.ndarray
    img_order: np.ndarray
    img_bounds: np.ndarray
    pair_a: np.ndarray
    pair_b: np.ndarray
    pair_bounds: np.ndarray
    pair_img: np.ndarray
    scatter_index: np.ndarray  # flat (nc+1)^2 index of every block entry (see blocks_to_matrix)

    @property
    def width(self) -> int:
        return int(self.img_cols.shape[1])

    @classmethod
    def from_network(cls, net) -> SchurLayout:
        p = net.project
        nc = net.n_cam_cols
        union = np.flatnonzero(net.io_free.any(axis=0))
        img_cols = np.concatenate([net.io_col[p.image_camera][:, union], net.eo_col], axis=1)
        img_cols = np.where(img_cols >= 0, img_cols, nc)
        n_img = p.n_images
        obs_image = np.asarray(p.obs_image)
        obs_point = np.asarray(p.obs_point)
        img_order = np.argsort(obs_image, kind="stable")
        img_bounds = np.searchsorted(obs_image[img_order], np.arange(n_img + 1))
        # Pairs of observations of the same point (each unordered pair once).
        order = np.lexsort((obs_image, obs_point))
        keys = obs_point[order]
        pa, pb = [], []
        for d in range(1, len(keys)):
            same = np.flatnonzero(keys[d:] == keys[:-d])
            if same.size == 0:
                break
            pa.append(order[same])
            pb.append(order[same + d])
        pair_a = np.concatenate(pa) if pa else np.zeros(0, int)
        pair_b = np.concatenate(pb) if pb else np.zeros(0, int)
        # Sorted by point then image, so image(a) < image(b) (one measurement per image
        # and point after Project.validate).
        key = obs_image[pair_a].astype(np.int64) * n_img + obs_image[pair_b]
        srt = np.argsort(key, kind="stable")
        pair_a, pair_b, key = pair_a[srt], pair_b[srt], key[srt]
        starts = np.flatnonzero(np.r_[True, key[1:] != key[:-1]]) if key.size else np.zeros(0, int)
        pair_bounds = np.append(starts, key.size)
        seg_key = key[starts]
        pair_img = np.column_stack([seg_key // n_img, seg_key % n_img]).astype(int)
        # Where each LxL block lands in the flat (nc+1)^2 matrix: the image blocks
        # (i, i), the pair blocks (i, j) and their mirrors (j, i).
        n1 = nc + 1

        def flat(rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
            return (rows[:, :, None] * n1 + cols[:, None, :]).ravel()

        ci, cj = img_cols[pair_img[:, 0]], img_cols[pair_img[:, 1]]
        scatter_index = np.concatenate([flat(img_cols, img_cols), flat(ci, cj), flat(cj, ci)])
        return cls(
            nc=nc,
            n_points=p.n_points,
            union=union,
            obs_point=obs_point,
            obs_image=obs_image,
            obs_cols=img_cols[obs_image],
            img_cols=img_cols,
            img_order=img_order,
            img_bounds=img_bounds,
            pair_a=pair_a,
            pair_b=pair_b,
            pair_bounds=pair_bounds,
            pair_img=pair_img,
            scatter_index=scatter_index,
        )

    @property
    def n_pairs(self) -> int:
        return len(self.pair_bounds) - 1

    def images(self):
        """Yield (image, cols (L,), observation indices) of every image."""
        for i in range(len(self.img_bounds) - 1):
            yield i, self.img_cols[i], self.img_order[self.img_bounds[i] : self.img_bounds[i + 1]]

    def image_pairs(self):
        """Yield (segment, image i, image j, obs in i, obs in j) of every image pair
        sharing points."""
        b = self.pair_bounds
        for s in range(len(b) - 1):
            i, j = self.pair_img[s]
            yield s, i, j, self.pair_a[b[s] : b[s + 1]], self.pair_b[b[s] : b[s + 1]]

    def blocks_to_matrix(self, img_blocks: np.ndarray, pair_blocks: np.ndarray) -> np.ndarray:
        """Sum (n_img,L,L) image blocks and (n_pairs,L,L) pair blocks (and their
        transposes) into the (nc,nc) camera matrix (one bincount)."""
        n1 = self.nc + 1
        vals = np.concatenate(
            [img_blocks.ravel(), pair_blocks.ravel(), pair_blocks.transpose(0, 2, 1).ravel()]
        )
        out = np.bincount(self.scatter_index, weights=vals, minlength=n1 * n1)
        return out.reshape(n1, n1)[: self.nc, : self.nc]

    def matrix_blocks(self, mat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The (n_img,L,L) image and (n_pairs,L,L) pair blocks of an (nc,nc) matrix."""
        n1 = self.nc + 1
        pad = np.zeros((n1, n1))
        pad[: self.nc, : self.nc] = mat
        w = self.width
        n_img = self.img_cols.shape[0]
        vals = pad.ravel()[self.scatter_index[: (n_img + self.n_pairs) * w * w]]
        return vals[: n_img * w * w].reshape(n_img, w, w), vals[n_img * w * w :].reshape(-1, w, w)


@dataclass
class PointCameraSystem:
    """Normal equations of one linearisation, reduced to the camera parameters.

    Built by :meth:`build`; ``s`` is the reduced camera matrix, ``g_cam`` and
    ``g_op`` the gradient ``J^T r`` parts.
    """

    layout: SchurLayout
    a: np.ndarray  # (N,3,3)
    g_op: np.ndarray  # (N,3)
    c: np.ndarray  # (nc,nc)
    g_cam: np.ndarray  # (nc,)
    b: np.ndarray  # (m,3,L) per observation
    jp: np.ndarray  # (m,2,3) weighted point Jacobian (fixed coordinates zeroed)
    jc: np.ndarray  # (m,2,L) weighted camera Jacobian
    a_inv: np.ndarray | None = None
    t: np.ndarray | None = None  # (m,3,L) A^-1 B per observation
    s: np.ndarray | None = None

    @property
    def nc(self) -> int:
        return self.layout.nc

    # ------------------------------------------------------------------ build
    @classmethod
    def build(cls, net, st, r: np.ndarray, jac, layout: SchurLayout | None = None):
        """Normal-equation blocks of the linearisation ``jac`` at residual ``r``."""
        lay = layout if layout is not None else SchurLayout.from_network(net)
        p = net.project
        d_xyz, d_eo, d_io = jac
        w = net.sqrt_w[:, :, None]
        jp = d_xyz * w
        if not net.op_free.all():
            jp = jp * net.op_free[p.obs_point][:, None, :]
        # Columns of fixed parameters go to the dummy column nc (dropped everywhere).
        jc = np.concatenate([d_io[:, :, lay.union], d_eo], axis=2) * w
        m = jp.shape[0]
        npt = p.n_points
        nc = lay.nc
        r_img = r[: 2 * m].reshape(m, 2)
        # Point blocks and gradient.
        jtj = np.empty((m, 6))
        for n_, (i, j) in enumerate(((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))):
            jtj[:, n_] = jp[:, 0, i] * jp[:, 0, j] + jp[:, 1, i] * jp[:, 1, j]
        u = _sum_by(p.obs_point, jtj, npt)
        a = u[:, [0, 1, 2, 1, 3, 4, 2, 4, 5]].reshape(npt, 3, 3)
        jtr = jp[:, 0, :] * r_img[:, 0:1] + jp[:, 1, :] * r_img[:, 1:2]
        g_op = _sum_by(p.obs_point, jtr, npt)
        op_m = np.isfinite(net.op_prior_std)
        if np.any(op_m):
            wgt = np.where(op_m, 1.0 / net.op_prior_std**2, 0.0)
            a[:, [0, 1, 2], [0, 1, 2]] += wgt
            g_op += np.where(op_m, (st.xyz - net.op_prior) / net.op_prior_std**2, 0.0)
        fixed = ~net.op_free
        fi, fj = np.nonzero(fixed)
        a[fi, fj, :] = 0.0
        a[fi, :, fj] = 0.0
        a[fi, fj, fj] = 1.0
        g_op[fixed] = 0.0
        # Camera block C: one dense Gram matrix per image (every observation of an
        # image has the same camera columns).
        width = lay.width
        gram = np.zeros((len(lay.img_cols), width, width))
        for i, _, idx in lay.images():
            x = jc[idx].reshape(-1, width)
            gram[i] = x.T @ x
        ext = lay.blocks_to_matrix(gram, np.zeros((lay.n_pairs, width, width)))
        jtr_c = jc[:, 0, :] * r_img[:, 0:1] + jc[:, 1, :] * r_img[:, 1:2]
        g_cam = np.bincount(lay.obs_cols.ravel(), weights=jtr_c.ravel(), minlength=nc + 1)[:nc]
        c = ext.copy()
        eo_m = np.isfinite(net.eo_prior_std)
        if np.any(eo_m):
            idx = net.eo_col[eo_m]
            c[idx, idx] += 1.0 / net.eo_prior_std[eo_m] ** 2
            g_cam[idx] += (st.eo[eo_m] - net.eo_prior[eo_m]) / net.eo_prior_std[eo_m] ** 2
        # Coupling blocks B_k = Jp_k^T Jc_k (3xL).
        b = _bmm(jp.transpose(0, 2, 1), jc)
        return cls(layout=lay, a=a, g_op=g_op, c=c, g_cam=g_cam, b=b, jp=jp, jc=jc)

    # ------------------------------------------------------------- reduce
    def reduce(self, lam: float = 0.0, raise_singular=None) -> None:
        """Inverse point blocks and the reduced camera matrix (Marquardt damping ``lam``)."""
        lay = self.layout
        a = self.a
        c = self.c
        if lam > 0:
            a = a.copy()
            a[:, [0, 1, 2], [0, 1, 2]] *= 1.0 + lam
            c = c.copy()
            c[np.diag_indices_from(c)] *= 1.0 + lam
        det = np.linalg.det(a)
        scale = np.einsum("nii->n", a) ** 3
        bad = ~(np.abs(det) > 1e-14 * np.abs(scale))
        if np.any(bad) and raise_singular is not None:
            raise_singular(np.flatnonzero(bad))
        self.a_inv = np.linalg.inv(a)
        self.t = _bmm(self.a_inv[lay.obs_point], self.b)
        width = lay.width
        b, t = self.b, self.t
        img_blk = np.zeros((len(lay.img_cols), width, width))
        pair_blk = np.empty((lay.n_pairs, width, width))
        for i, _, idx in lay.images():
            img_blk[i] = b[idx].reshape(-1, width).T @ t[idx].reshape(-1, width)
        for s, _, _, ka, kb in lay.image_pairs():
            pair_blk[s] = b[ka].reshape(-1, width).T @ t[kb].reshape(-1, width)
        self.s = c - lay.blocks_to_matrix(img_blk, pair_blk)

    # -------------------------------------------------------------- solve
    def back_substitute(self, dc: np.ndarray) -> np.ndarray:
        """Point step ``dp_p = A_p^-1 (-g_p - B_p dc)`` (N,3)."""
        lay = self.layout
        dcz = np.append(dc, 0.0)  # dummy column -> 0
        v = np.einsum("mij,mj->mi", self.b, dcz[lay.obs_cols])
        rhs = -self.g_op - _sum_by(lay.obs_point, v, lay.n_points)
        return np.einsum("nij,nj->ni", self.a_inv, rhs)

    def reduced_rhs(self) -> np.ndarray:
        """``-(g_cam - B^T A^-1 g_op)``."""
        lay = self.layout
        y = np.einsum("nij,nj->ni", self.a_inv, self.g_op)  # A^-1 g
        v = np.einsum("mia,mi->ma", self.b, y[lay.obs_point])
        acc = np.bincount(lay.obs_cols.ravel(), weights=v.ravel(), minlength=lay.nc + 1)
        return -(self.g_cam - acc[: lay.nc])

    # ---------------------------------------------------------- posterior
    def posterior(self, cov_cam: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Unscaled point covariance blocks and the hat-matrix diagonal of the images.

        With ``Q = S^-1`` and ``T_p = A_p^-1 B_p``, the point block is
        ``Q_pp = A_p^-1 + T_p Q T_p^T`` and the cross block ``Q_pc = -T_p Q``.  For
        every observation, ``V_k = sum_{l in p} T_l Q[c_l, c_k] = -Q_pc[:, c_k]``
        is accumulated over the image pairs, then

            Q_pp = A^-1 + sum_k V_k T_k^T,
            h_k = Jp_k Q_pp Jp_k^T + Jc_k Q[c_k, c_k] Jc_k^T - 2 Jp_k V_k Jc_k^T

        (diagonal of ``J N^-1 J^T``, weighted; redundancy number ``1 - h``).

        Returns
        -------
        cov_points : (N,3,3); hat : (m,2).
        """
        lay = self.layout
        width = lay.width
        q_img, q_pair = lay.matrix_blocks(cov_cam)
        t = self.t
        v = np.zeros_like(t)
        hat_c = np.zeros(self.jc.shape[:2])
        for i, _, idx in lay.images():
            v[idx] += (t[idx].reshape(-1, width) @ q_img[i]).reshape(-1, 3, width)
            x = self.jc[idx].reshape(-1, width)
            hat_c[idx] = np.einsum("kl,kl->k", x @ q_img[i], x).reshape(-1, 2)
        for s, _, _, ka, kb in lay.image_pairs():
            v[kb] += (t[ka].reshape(-1, width) @ q_pair[s]).reshape(-1, 3, width)
            v[ka] += (t[kb].reshape(-1, width) @ q_pair[s].T).reshape(-1, 3, width)
        vt = _bmm(v, t.transpose(0, 2, 1))
        q_pp = self.a_inv + _sum_by(lay.obs_point, vt, lay.n_points)
        jp = self.jp
        hat_p = np.einsum("kra,kab,krb->kr", jp, q_pp[lay.obs_point], jp)
        hat_x = np.einsum("kra,kal,krl->kr", jp, v, self.jc)
        return q_pp, hat_p + hat_c - 2.0 * hat_x
