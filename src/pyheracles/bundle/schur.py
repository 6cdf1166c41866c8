"""Block-structured normal equations of the bundle: Schur complement on the object points.

Each object point is a 3x3 block ``A_i``.  Its coupling with the camera
parameters is kept per observation (``B_k = Jp_k^T Je_k``, 3x6, exterior
orientation of the observing image) and per point and camera (``B_g``, 3xq,
interior orientation), so that the reduced camera matrix

    S = C - sum_i B_i^T A_i^-1 B_i

is assembled from small dense products over the pairs of observations of each
point (vectorised numpy, scattered with ``bincount``) instead of general sparse
matrix products: the cost is ``sum_i rays_i^2`` small blocks, the classic
reduced-camera-system cost (Triggs et al. 2000, "Bundle adjustment - a modern
synthesis", section 6).  The same pair lists give the posterior covariance
blocks of every point and the redundancy numbers of every observation.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["PointCameraSystem"]

_CHUNK = 250_000


def _same_key_pairs(keys_sorted: np.ndarray, max_count: int):
    """Yield (i, j) index arrays (i < j) of equal keys in a sorted key array."""
    n = len(keys_sorted)
    for d in range(1, max_count):
        if d >= n:
            break
        same = np.flatnonzero(keys_sorted[d:] == keys_sorted[:-d])
        if same.size == 0:
            break
        yield same, same + d


def _chunks(n: int, size: int = _CHUNK):
    for s in range(0, n, size):
        yield slice(s, min(n, s + size))


def _add_block(mat: np.ndarray, rows: np.ndarray, cols: np.ndarray, blk: np.ndarray) -> None:
    """``mat[rows, cols] += blk`` skipping the index -1 (fixed parameters)."""
    r, c = rows >= 0, cols >= 0
    mat[np.ix_(rows[r], cols[c])] += blk[np.ix_(r, c)]


class _Scatter:
    """Accumulate small dense blocks into a dense (n,n) matrix.

    Index -1 (a fixed parameter) goes to a dummy row/column n that is dropped.
    """

    def __init__(self, n: int) -> None:
        self.n = n
        self.flat = np.zeros((n + 1) * (n + 1))

    def add(self, rows: np.ndarray, cols: np.ndarray, vals: np.ndarray) -> None:
        """rows (k,a), cols (k,b), vals (k,a,b)."""
        n1 = self.n + 1
        r = np.where(rows >= 0, rows, self.n)
        c = np.where(cols >= 0, cols, self.n)
        idx = (r[:, :, None] * n1 + c[:, None, :]).ravel()
        if idx.size >= self.flat.size // 4:
            # Many entries for a small matrix: bincount is the fastest scatter.
            self.flat += np.bincount(idx, weights=vals.ravel(), minlength=self.flat.size)
        else:
            # np.add.at costs O(k), where a bincount would cost O(n^2) per call.
            np.add.at(self.flat, idx, vals.ravel())

    def matrix(self) -> np.ndarray:
        return self.flat.reshape(self.n + 1, self.n + 1)[: self.n, : self.n]


@dataclass
class PointCameraSystem:
    """Normal equations of one linearisation, reduced to the camera parameters.

    Built by :meth:`build`; ``s`` is the reduced camera matrix, ``g_cam`` and
    ``g_op`` the gradient ``J^T r`` parts.
    """

    nc: int
    a: np.ndarray  # (N,3,3)
    g_op: np.ndarray  # (N,3)
    c: np.ndarray  # (nc,nc)
    g_cam: np.ndarray  # (nc,)
    b_eo: np.ndarray  # (m,3,6) per observation
    eo_cols: np.ndarray  # (m,6)
    b_io: np.ndarray  # (G,3,q) per (point, camera) group
    io_cols: np.ndarray  # (G,q)
    obs_point: np.ndarray  # (m,)
    group_point: np.ndarray  # (G,)
    order_obs: np.ndarray  # observations sorted by point
    order_grp: np.ndarray  # groups sorted by point
    max_rays: int
    max_groups: int
    obs_image: np.ndarray  # (m,)
    img_order: np.ndarray  # observations sorted by image
    img_bounds: np.ndarray  # (n_img+1,) slices of img_order per image
    img_eo_cols: np.ndarray  # (n_img,6)
    a_inv: np.ndarray | None = None
    s: np.ndarray | None = None

    # ------------------------------------------------------------------ build
    @classmethod
    def build(cls, net, st, r: np.ndarray, jac) -> PointCameraSystem:
        p = net.project
        d_xyz, d_eo, d_io = jac
        w = net.sqrt_w[:, :, None]
        jp = d_xyz * w * net.op_free[p.obs_point][:, None, :]
        je = d_eo * w
        m = jp.shape[0]
        npt = p.n_points
        r_img = r[: 2 * m].reshape(m, 2)
        # Interior parameters free for at least one camera ("union"), q of them.
        union = np.flatnonzero(net.io_free.any(axis=0))
        ji = d_io[:, :, union] * w
        io_cols_obs = net.io_col[net.obs_cam][:, union]  # (m,q)
        eo_cols = net.eo_col[p.obs_image]  # (m,6)
        nc = net.n_cam_cols
        # Point blocks and gradient.
        jtj = jp.transpose(0, 2, 1) @ jp
        a = np.zeros((npt, 3, 3))
        for i in range(3):
            for j in range(i, 3):
                a[:, i, j] = np.bincount(p.obs_point, weights=jtj[:, i, j], minlength=npt)
                a[:, j, i] = a[:, i, j]
        jtr = np.einsum("mki,mk->mi", jp, r_img)
        g_op = np.column_stack(
            [np.bincount(p.obs_point, weights=jtr[:, i], minlength=npt) for i in range(3)]
        )
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
        # Camera block C = Jc^T Jc and gradient: every observation of an image has the
        # same camera columns, so C is a sum of one dense Gram matrix per image (BLAS).
        n_img = p.n_images
        order_img = np.argsort(p.obs_image, kind="stable")
        bounds = np.searchsorted(p.obs_image[order_img], np.arange(n_img + 1))
        img_cols = np.concatenate([net.io_col[p.image_camera][:, union], net.eo_col], axis=1)
        c = np.zeros((nc, nc))
        for i in range(n_img):
            idx = order_img[bounds[i] : bounds[i + 1]]
            if not len(idx):
                continue
            x = np.concatenate([ji[idx], je[idx]], axis=2).reshape(-1, len(union) + 6)
            _add_block(c, img_cols[i], img_cols[i], x.T @ x)
        g_cam = np.zeros(nc + 1)
        jtr_c = np.concatenate(
            [np.einsum("mki,mk->mi", ji, r_img), np.einsum("mki,mk->mi", je, r_img)], axis=1
        )
        cols_all = np.concatenate([io_cols_obs, eo_cols], axis=1)
        ok = cols_all >= 0
        g_cam[:nc] = np.bincount(cols_all[ok], weights=jtr_c[ok], minlength=nc)[:nc]
        g_cam = g_cam[:nc]
        eo_m = np.isfinite(net.eo_prior_std)
        if np.any(eo_m):
            idx = net.eo_col[eo_m]
            c[idx, idx] += 1.0 / net.eo_prior_std[eo_m] ** 2
            g_cam[idx] += (st.eo[eo_m] - net.eo_prior[eo_m]) / net.eo_prior_std[eo_m] ** 2
        # Coupling blocks.
        b_eo = jp.transpose(0, 2, 1) @ je  # (m,3,6)
        ncam = len(p.cameras)
        gkey = p.obs_point * ncam + net.obs_cam
        ukeys, ginv = np.unique(gkey, return_inverse=True)
        n_grp = len(ukeys)
        bio_obs = jp.transpose(0, 2, 1) @ ji  # (m,3,q)
        q = len(union)
        b_io = np.zeros((n_grp, 3, q))
        for i in range(3):
            for j in range(q):
                b_io[:, i, j] = np.bincount(ginv, weights=bio_obs[:, i, j], minlength=n_grp)
        group_point = ukeys // ncam
        group_cam = ukeys % ncam
        io_cols = net.io_col[group_cam][:, union] if q else np.zeros((n_grp, 0), int)
        order_obs = np.argsort(p.obs_point, kind="stable")
        order_grp = np.argsort(group_point, kind="stable")
        rays = np.bincount(p.obs_point, minlength=npt)
        grp_count = np.bincount(group_point, minlength=npt)
        return cls(
            nc=nc,
            a=a,
            g_op=g_op,
            c=c,
            g_cam=g_cam,
            b_eo=b_eo,
            eo_cols=eo_cols,
            b_io=b_io,
            io_cols=io_cols,
            obs_point=p.obs_point,
            group_point=group_point,
            order_obs=order_obs,
            order_grp=order_grp,
            max_rays=int(rays.max()) if npt else 0,
            max_groups=int(grp_count.max()) if npt else 0,
            obs_image=p.obs_image,
            img_order=order_img,
            img_bounds=bounds,
            img_eo_cols=net.eo_col,
        )

    # ------------------------------------------------------------- reduce
    def _pairs_obs_obs(self):
        """(k, l) observation pairs of the same point, k != l (each unordered pair once)."""
        keys = self.obs_point[self.order_obs]
        for i, j in _same_key_pairs(keys, self.max_rays):
            yield self.order_obs[i], self.order_obs[j]

    def _pairs_grp_grp(self):
        keys = self.group_point[self.order_grp]
        for i, j in _same_key_pairs(keys, self.max_groups):
            yield self.order_grp[i], self.order_grp[j]

    def _pairs_grp_obs(self):
        """(g, k) pairs: every group of the point of every observation."""
        npt = self.a.shape[0]
        counts = np.bincount(self.group_point, minlength=npt)
        start = np.concatenate([[0], np.cumsum(counts)[:-1]])
        k_all = np.arange(len(self.obs_point))
        for j in range(self.max_groups):
            pt = self.obs_point
            ok = counts[pt] > j
            k = k_all[ok]
            yield self.order_grp[start[pt[ok]] + j], k

    def reduce(self, lam: float = 0.0, raise_singular=None) -> None:
        """Inverse point blocks and the reduced camera matrix (Marquardt damping ``lam``)."""
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
        ainv = self.a_inv
        sc = _Scatter(self.nc)  # symmetric terms
        pairs = _Scatter(self.nc)  # one of the two mirrored blocks of every pair term
        pt_obs = self.obs_point
        t_eo = ainv[pt_obs] @ self.b_eo
        # EO-EO diagonal terms: one Gram-like product per image (same columns).
        diag = np.zeros((self.nc, self.nc))
        for i in range(len(self.img_bounds) - 1):
            idx = self.img_order[self.img_bounds[i] : self.img_bounds[i + 1]]
            if len(idx):
                x = self.b_eo[idx].reshape(-1, 6)
                y = t_eo[idx].reshape(-1, 6)
                _add_block(diag, self.img_eo_cols[i], self.img_eo_cols[i], -(x.T @ y))
        # EO-EO pairs (k, l) of the same point: block (k, l), mirrored at the end.
        for k, l_ in self._pairs_obs_obs():
            for sl in _chunks(len(k)):
                kk, ll = k[sl], l_[sl]
                blk = -self.b_eo[kk].transpose(0, 2, 1) @ t_eo[ll]
                pairs.add(self.eo_cols[kk], self.eo_cols[ll], blk)
        if self.b_io.shape[2]:
            gp = self.group_point
            t_io = ainv[gp] @ self.b_io
            sc.add(self.io_cols, self.io_cols, -self.b_io.transpose(0, 2, 1) @ t_io)
            for g, h in self._pairs_grp_grp():
                blk = -self.b_io[g].transpose(0, 2, 1) @ t_io[h]
                pairs.add(self.io_cols[g], self.io_cols[h], blk)
            for g, k in self._pairs_grp_obs():
                for sl in _chunks(len(k)):
                    gg, kk = g[sl], k[sl]
                    blk = -t_io[gg].transpose(0, 2, 1) @ self.b_eo[kk]
                    pairs.add(self.io_cols[gg], self.eo_cols[kk], blk)
        m = pairs.matrix()
        self.s = c + diag + sc.matrix() + m + m.T

    # -------------------------------------------------------------- solve
    def back_substitute(self, dc: np.ndarray) -> np.ndarray:
        """Point step ``dp_i = A_i^-1 (-g_i - B_i dc)`` (N,3)."""
        npt = self.a.shape[0]
        dcz = np.append(dc, 0.0)  # index -1 -> 0
        rhs = -self.g_op.copy()
        v = np.einsum("mij,mj->mi", self.b_eo, dcz[self.eo_cols])
        for i in range(3):
            rhs[:, i] -= np.bincount(self.obs_point, weights=v[:, i], minlength=npt)
        if self.b_io.shape[2]:
            v = np.einsum("gij,gj->gi", self.b_io, dcz[self.io_cols])
            for i in range(3):
                rhs[:, i] -= np.bincount(self.group_point, weights=v[:, i], minlength=npt)
        return np.einsum("nij,nj->ni", self.a_inv, rhs)

    def reduced_rhs(self) -> np.ndarray:
        """``-(g_cam - B^T A^-1 g_op)``."""
        y = np.einsum("nij,nj->ni", self.a_inv, self.g_op)  # A^-1 g
        out = self.g_cam.copy()
        acc = np.zeros(self.nc + 1)
        v = np.einsum("mia,mi->ma", self.b_eo, y[self.obs_point])
        cols = np.where(self.eo_cols >= 0, self.eo_cols, self.nc)
        acc += np.bincount(cols.ravel(), weights=v.ravel(), minlength=self.nc + 1)
        if self.b_io.shape[2]:
            v = np.einsum("gia,gi->ga", self.b_io, y[self.group_point])
            cols = np.where(self.io_cols >= 0, self.io_cols, self.nc)
            acc += np.bincount(cols.ravel(), weights=v.ravel(), minlength=self.nc + 1)
        return -(out - acc[: self.nc])

    # ---------------------------------------------------------- posterior
    def _blocks(self, cov_cam: np.ndarray):
        """T blocks (A^-1 B) of observations (EO) and groups (IO)."""
        ainv = self.a_inv
        t_eo = ainv[self.obs_point] @ self.b_eo
        t_io = ainv[self.group_point] @ self.b_io if self.b_io.shape[2] else None
        return t_eo, t_io

    def point_covariances(self, cov_cam: np.ndarray) -> np.ndarray:
        """(N,3,3) unscaled point covariance blocks ``A^-1 + T S^-1 T^T``."""
        npt = self.a.shape[0]
        out = self.a_inv.copy()
        qz = np.zeros((self.nc + 1, self.nc + 1))
        qz[: self.nc, : self.nc] = cov_cam
        t_eo, t_io = self._blocks(cov_cam)
        ec = np.where(self.eo_cols >= 0, self.eo_cols, self.nc)
        flat = np.zeros(npt * 9)

        def add(pts, ta, ca, tb, cb, sym):
            sub = qz[ca[:, :, None], cb[:, None, :]]  # (k,a,b)
            blk = (ta @ sub) @ tb.transpose(0, 2, 1)
            if sym:
                blk = blk + blk.transpose(0, 2, 1)
            idx = (pts * 9)[:, None] + np.arange(9)[None, :]
            return np.bincount(idx.ravel(), weights=blk.reshape(-1, 9).ravel(),
                               minlength=npt * 9)  # fmt: skip

        for sl in _chunks(len(self.obs_point)):
            flat += add(self.obs_point[sl], t_eo[sl], ec[sl], t_eo[sl], ec[sl], False)
        for k, l_ in self._pairs_obs_obs():
            for sl in _chunks(len(k)):
                kk, ll = k[sl], l_[sl]
                flat += add(self.obs_point[kk], t_eo[kk], ec[kk], t_eo[ll], ec[ll], True)
        if t_io is not None:
            ic = np.where(self.io_cols >= 0, self.io_cols, self.nc)
            gp = self.group_point
            flat += add(gp, t_io, ic, t_io, ic, False)
            for g, h in self._pairs_grp_grp():
                flat += add(gp[g], t_io[g], ic[g], t_io[h], ic[h], True)
            for g, k in self._pairs_grp_obs():
                for sl in _chunks(len(k)):
                    gg, kk = g[sl], k[sl]
                    flat += add(gp[gg], t_io[gg], ic[gg], t_eo[kk], ec[kk], True)
        return out + flat.reshape(npt, 3, 3)

    def cross_covariances(self, cov_cam: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """Per observation k: ``Q_pc[:, cols_k] = -sum_u T_u S^-1[cols_u, cols_k]`` (m,3,L)."""
        m = len(self.obs_point)
        qz = np.zeros((self.nc + 1, self.nc + 1))
        qz[: self.nc, : self.nc] = cov_cam
        t_eo, t_io = self._blocks(cov_cam)
        ec = np.where(self.eo_cols >= 0, self.eo_cols, self.nc)
        cz = np.where(cols >= 0, cols, self.nc)
        out = np.zeros((m, 3, cols.shape[1]))
        for sl in _chunks(m):
            out[sl] -= t_eo[sl] @ qz[ec[sl][:, :, None], cz[sl][:, None, :]]
        for k, l_ in self._pairs_obs_obs():
            for sl in _chunks(len(k)):
                kk, ll = k[sl], l_[sl]
                v1 = t_eo[ll] @ qz[ec[ll][:, :, None], cz[kk][:, None, :]]
                out[kk] -= v1  # unique within one offset
                v2 = t_eo[kk] @ qz[ec[kk][:, :, None], cz[ll][:, None, :]]
                out[ll] -= v2
        if t_io is not None:
            ic = np.where(self.io_cols >= 0, self.io_cols, self.nc)
            for g, k in self._pairs_grp_obs():
                v = t_io[g] @ qz[ic[g][:, :, None], cz[k][:, None, :]]
                out[k] -= v
        return out
