"""Benchmarks of registration and georeferencing (issue 5).

Run ``python benchmarks/bench_registration.py [section ...]`` with sections
``montecarlo``, ``badinput``, ``church``, ``churchseeds``, ``icp``, ``bunny`` (default: all;
``churchseeds`` checks the noise model on 100 generated churches, 15-20 min;
``churchpanes`` reports the glass coverage of the windows in six church family draws).
``--sweep N [--first-seed S] [--model rigid|similarity]`` instead runs today's automatic
registration (window pane tie points, ``heracles register --auto``) over N draws of the
``church`` scene family (issue 14 targets: interior check point RMS <= 1.5 cm; a wrong
transform (> 5 cm) returned without a failure flag counted apart), with the manual
sphere-target path as a sanity check per draw.  Prints JSON lines.
"""

from __future__ import annotations

import os
import sys

from _common import SHARED_DATA, emit, interruptible, timer

import numpy as np

from pyheracles.registration.similarity import (
    ESTIMATORS,
    PARAMETER_NAMES,
    SimilarityParams,
    estimate_similarity,
    similarity_matrix,
)


def bench_montecarlo(runs: int = 300, seed: int = 2026) -> None:
    """Normalised parameter errors and blunder detection rates (>= 200 runs)."""
    rng = np.random.default_rng(seed)
    sigma = 0.01  # 1 cm per coordinate
    true = np.array([452103.25, 5411020.5, 148.2, 0.012, -0.008, 1.1, 1.00025])
    T = similarity_matrix(true[:3], true[3:6], true[6])
    src = rng.uniform([-15, -8, 0], [15, 8, 12], (12, 3))  # one fixed geometry
    z = np.zeros((runs, 7))
    s0 = np.zeros(runs)
    with timer() as t:
        for i in range(runs):
            tgt = src @ T[:3, :3].T + T[:3, 3] + rng.normal(0.0, sigma, src.shape)
            res = estimate_similarity(src, tgt, SimilarityParams(sigma_m=sigma))
            est = np.array([res.parameters[k] for k in PARAMETER_NAMES])
            sd = np.array([res.std[k] for k in PARAMETER_NAMES])
            z[i] = (est - true) / sd
            s0[i] = res.sigma0
    spread = z.std(axis=0)
    for k, name in enumerate(PARAMETER_NAMES):
        emit(
            dataset="montecarlo_12pairs_1cm",
            metric=f"normalised_error_std_{name}",
            value=float(spread[k]),
            target="0.8-1.25",
            reached=bool(0.8 <= spread[k] <= 1.25),
            runs=runs,
            time_s=t.s,
            points_per_s=None,
        )
    emit(dataset="montecarlo_12pairs_1cm", metric="mean_sigma0", value=float(s0.mean()), runs=runs)
    for est_name in ESTIMATORS:
        hits = 0
        false_alarms = 0
        with timer() as t:
            for _ in range(runs):
                src_b = rng.uniform([-15, -8, 0], [15, 8, 12], (12, 3))
                tgt = src_b @ T[:3, :3].T + T[:3, 3] + rng.normal(0.0, sigma, src_b.shape)
                bad = int(rng.integers(12))
                d = rng.normal(size=3)
                tgt[bad] += 0.10 * d / np.linalg.norm(d)
                res = estimate_similarity(
                    src_b, tgt, SimilarityParams(estimator=est_name, sigma_m=sigma)
                )
                hits += bool(res.outliers[bad])
                false_alarms += int(res.outliers.sum()) - bool(res.outliers[bad])
        emit(
            dataset="montecarlo_12pairs_1cm_10cm_blunder",
            metric=f"blunder_detection_rate_{est_name}",
            value=hits / runs,
            target=">=0.95",
            reached=hits / runs >= 0.95,
            false_alarms_per_run=false_alarms / runs,
            runs=runs,
            time_s=t.s,
            points_per_s=None,
        )


def _rot_err_deg(T: np.ndarray, T_true: np.ndarray) -> float:
    from scipy.spatial.transform import Rotation

    dR = T[:3, :3] @ T_true[:3, :3].T
    return float(np.degrees(np.linalg.norm(Rotation.from_matrix(dR).as_rotvec())))


def bench_icp(n: int = 2_000_000, seed: int = 5) -> None:
    """ICP of two 2 M point clouds (target <= 20 s), with Open3D as peer if it imports."""
    from scipy.spatial.transform import Rotation

    from pyheracles.cloud import PointCloud
    from pyheracles.registration.icp import ICPParams, icp

    rng = np.random.default_rng(seed)

    def surface(m: int) -> np.ndarray:
        uv = rng.uniform(0, 100, (m, 2))
        z = 2.0 * np.sin(0.3 * uv[:, 0]) * np.cos(0.2 * uv[:, 1]) + 0.5 * np.sin(1.3 * uv[:, 1])
        return np.column_stack([uv, z]) + np.array([1049800.0, 6842300.0, 140.0])

    target = surface(n) + rng.normal(0, 0.005, (n, 3))
    T_true = np.eye(4)
    T_true[:3, :3] = Rotation.from_euler("xyz", [0.2, -0.3, 0.5], degrees=True).as_matrix()
    c = target.mean(0)
    T_true[:3, 3] = c - T_true[:3, :3] @ c + [0.05, -0.04, 0.03]
    src_true = surface(n)  # independent sampling of the same surface
    src = (src_true - T_true[:3, 3]) @ T_true[:3, :3] + rng.normal(0, 0.005, (n, 3))
    src_pc = PointCloud.from_world(src)
    tgt_pc = PointCloud.from_world(target)
    import os
    import time

    cpu0 = time.process_time()
    load0 = os.getloadavg()[0]
    with timer() as t:
        res = icp(src_pc, tgt_pc, params=ICPParams(max_correspondence_m=0.5))
    cpu = time.process_time() - cpu0
    moved = src @ res.T_target_source[:3, :3].T + res.T_target_source[:3, 3]
    truth = src @ T_true[:3, :3].T + T_true[:3, 3]
    emit(
        dataset="synthetic_surface_2M_2M",
        metric="icp_time_s",
        value=t.s,
        target="<=20 s",
        reached=t.s <= 20.0,
        time_s=t.s,
        cpu_s=cpu,
        load_average_1min=load0,
        points_per_s=2 * n / t.s,
        rot_error_deg=_rot_err_deg(res.T_target_source, T_true),
        max_point_error_m=float(np.abs(moved - truth).max()),
        rms_point_to_plane_m=res.rms_point_to_plane_m,
        overlap=res.overlap_fraction,
        iterations=res.iterations,
        converged=res.converged,
    )
    try:
        import open3d as o3d
    except Exception as exc:  # open3d may be missing or fail to load a system library
        emit(
            dataset="synthetic_surface_2M_2M",
            metric="open3d_icp_time_s",
            value=None,
            note=f"open3d not importable: {exc}",
        )
        return
    a = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(src - tgt_pc.offset))
    b = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(target - tgt_pc.offset))
    with timer() as t2:
        b.estimate_normals(o3d.geometry.KDTreeSearchParamKNN(12))
        reg = o3d.pipelines.registration.registration_icp(
            a,
            b,
            0.5,
            np.eye(4),
            o3d.pipelines.registration.TransformationEstimationPointToPlane(),
        )
    emit(
        dataset="synthetic_surface_2M_2M",
        metric="open3d_icp_time_s",
        value=t2.s,
        time_s=t2.s,
        ratio_pyheracles_over_open3d=t.s / t2.s,
        fitness=reg.fitness,
    )


def bench_bunny() -> None:
    """Real data: Stanford bunny scans registered pairwise against the true poses."""
    from scipy.spatial.transform import Rotation

    from pyheracles.io import read_cloud
    from pyheracles.registration.icp import icp

    folder = SHARED_DATA / "bunny"
    if not folder.is_dir():
        emit(dataset="bunny", metric="skipped", value=None, note=f"{folder} missing")
        return
    poses = {}
    for line in (folder / "bun.conf").read_text().splitlines():
        f = line.split()
        if f and f[0] == "bmesh":
            T = np.eye(4)
            T[:3, :3] = Rotation.from_quat(np.array(f[5:9], float)).inv().as_matrix()
            T[:3, 3] = np.array(f[2:5], float)
            poses[f[1]] = T
    rng = np.random.default_rng(0)
    for a, b in [
        ("bun000.ply", "bun045.ply"),
        ("bun045.ply", "bun090.ply"),
        ("bun000.ply", "bun315.ply"),
        ("bun270.ply", "bun315.ply"),
    ]:
        tgt = read_cloud(folder / a)
        src = read_cloud(folder / b)
        T_true = np.linalg.inv(poses[a]) @ poses[b]
        pert = np.eye(4)
        pert[:3, :3] = Rotation.from_rotvec(
            np.radians(3.0) * (lambda v: v / np.linalg.norm(v))(rng.normal(size=3))
        ).as_matrix()
        pert[:3, 3] = rng.normal(0, 0.003, 3)
        with timer() as t:
            res = icp(src, tgt, pert @ T_true)
        emit(
            dataset=f"bunny_{b[:-4]}_to_{a[:-4]}",
            metric="icp_rotation_error_deg",
            value=_rot_err_deg(res.T_target_source, T_true),
            translation_error_m=float(np.linalg.norm(res.T_target_source[:3, 3] - T_true[:3, 3])),
            start_rotation_error_deg=3.0,
            rms_point_to_plane_m=res.rms_point_to_plane_m,
            overlap=res.overlap_fraction,
            converged=res.converged,
            time_s=t.s,
            points_per_s=(len(src) + len(tgt)) / t.s,
        )


def _church_rms(scene, me, mi, T_e, T_i) -> float:
    from pyheracles.registration.checkpoints import check_points
    from pyheracles.registration.points import PointList, pair_points
    from pyheracles.registration.transform import apply_to_points

    meas = PointList(
        me.ids + mi.ids, np.vstack([apply_to_points(T_e, me.xyz), apply_to_points(T_i, mi.xyz)])
    )
    pr = pair_points(meas, scene.check, unmatched="ignore")
    return check_points(pr.b, pr.a, pr.ids).rms["3d"]


def _noise_bound(scene, me, mi, ties_e, ties_i, runs: int, rng) -> np.ndarray:
    """Monte Carlo cross-check of :func:`_propagated_bound` (same noise model).

    Every measurement is replaced by its true value plus Gaussian noise of its stated
    standard deviation (survey sigma for control and check references, formal fit sigma
    for sphere centres, picking sigma for tie points); the same free-network
    estimator runs on it.  Returns the 3D check point RMS of each run;
    ``sqrt(mean(RMS^2))`` estimates the expected RMS with a Monte Carlo error of
    about ``1 / sqrt(2 runs)`` (5 % for 200 runs).
    """
    from pyheracles.registration.points import PointList
    from pyheracles.registration.strategies import CloudMeasurements, free_network
    from pyheracles.registration.transform import apply_to_points

    Tew = np.linalg.inv(scene.T_world_exterior)
    Tiw = np.linalg.inv(scene.T_world_interior)
    truth = scene.targets_true_world
    corners = scene.corners_world
    sc = scene.control
    ck = scene.check

    def noisy(pl, xyz_true):
        return PointList(pl.ids, xyz_true + rng.normal(0, 1, xyz_true.shape) * pl.sigma, pl.sigma)

    ms = []
    for _ in range(runs):
        e = noisy(me, apply_to_points(Tew, truth.select(me.ids).xyz))
        i = noisy(mi, apply_to_points(Tiw, truth.select(mi.ids).xyz))
        te = noisy(ties_e, apply_to_points(Tew, corners.select(ties_e.ids).xyz))
        ti = noisy(ties_i, apply_to_points(Tiw, corners.select(ties_i.ids).xyz))
        ctrl = noisy(sc, truth.select(sc.ids).xyz)
        fn = free_network(
            CloudMeasurements("exterior", e, True),
            CloudMeasurements("interior", i, False),
            te,
            ti,
            ctrl,
        )
        chk = noisy(ck, truth.select(ck.ids).xyz)
        fake = type(scene)(**{**scene.__dict__, "check": chk})
        ms.append(_church_rms(fake, e, i, fn.T_world_base, fn.T_world_other) ** 2)
    return np.sqrt(np.array(ms))


def _free_network_problem(scene, me, mi, ties_e, ties_i):
    """Expected free-network check point RMS by first-order propagation of all noise.

    Observations and their standard deviations (the noise model of the generator):

    - sphere centres of the control targets in each cloud (formal sigma of the fit),
    - tie points picked in both clouds (picking sigma, 1 cm),
    - control coordinates (survey sigma, 3 mm),
    - sphere centres of the check targets in each cloud (formal fit sigma),
    - check point references (survey sigma, 3 mm).

    The residual of check point ``k`` is ``r_k = X_k^ref - T_world_cloud(x_k)``, where
    ``T_world_cloud`` comes out of the free network (tie similarity, then one block
    similarity to all control points) run on all these observations.  With ``J`` the
    Jacobian of all residuals with respect to all observations (forward differences
    through the full chain: tie fit, propagated weights, block fit, data snooping) and
    ``S = diag(sigma^2)``, the residual covariance is ``C = J S J^T`` and

        E[RMS_3D^2] = trace(C) / n_check.

    This is "what the noise allows" for this estimator: it contains the noise of the
    check references and check measurements themselves (about 5.3 mm 3D for 3 mm survey
    noise), the propagated transform errors of both clouds, and the correlations the
    shared tie and block transforms induce.  It uses no result of the run being judged
    except as linearisation point.

    Returns ``(residual_fn, observations, sigma, true_errors, groups)``.
    """
    from pyheracles.registration.points import PointList, pair_points
    from pyheracles.registration.strategies import CloudMeasurements, free_network
    from pyheracles.registration.transform import apply_to_points

    ctrl_ids = set(scene.control.ids)
    Tew = np.linalg.inv(scene.T_world_exterior)
    Tiw = np.linalg.inv(scene.T_world_interior)
    truth = scene.targets_true_world
    corners = scene.corners_world

    def split(pl):
        c = [i for i in pl.ids if i in ctrl_ids]
        k = [i for i in pl.ids if i not in ctrl_ids]
        return pl.select(c), pl.select(k)

    me_c, me_k = split(me)
    mi_c, mi_k = split(mi)
    lists = {
        "control_targets_exterior": (me_c, apply_to_points(Tew, truth.select(me_c.ids).xyz)),
        "control_targets_interior": (mi_c, apply_to_points(Tiw, truth.select(mi_c.ids).xyz)),
        "ties_exterior": (ties_e, apply_to_points(Tew, corners.select(ties_e.ids).xyz)),
        "ties_interior": (ties_i, apply_to_points(Tiw, corners.select(ties_i.ids).xyz)),
        "control_coordinates": (scene.control, truth.select(scene.control.ids).xyz),
        "check_targets_exterior": (me_k, apply_to_points(Tew, truth.select(me_k.ids).xyz)),
        "check_targets_interior": (mi_k, apply_to_points(Tiw, truth.select(mi_k.ids).xyz)),
        "check_references": (scene.check, truth.select(scene.check.ids).xyz),
    }
    groups, start = {}, 0
    for name, (pl, _) in lists.items():
        groups[name] = np.arange(start, start + 3 * len(pl))
        start += 3 * len(pl)
    x0 = np.concatenate([pl.xyz.reshape(-1) for pl, _ in lists.values()])
    sig = np.concatenate([pl.sigma.reshape(-1) for pl, _ in lists.values()])
    err = x0 - np.concatenate([t.reshape(-1) for _, t in lists.values()])

    def unpack(x):
        return {
            k: PointList(pl.ids, x[groups[k]].reshape(-1, 3), pl.sigma)
            for k, (pl, _) in lists.items()
        }

    def residuals(x):
        o = unpack(x)

        def cat(a, b):
            return PointList(
                a.ids + b.ids, np.vstack([a.xyz, b.xyz]), np.vstack([a.sigma, b.sigma])
            )

        e = cat(o["control_targets_exterior"], o["check_targets_exterior"])
        i = cat(o["control_targets_interior"], o["check_targets_interior"])
        fn = free_network(
            CloudMeasurements("exterior", e, True),
            CloudMeasurements("interior", i, False),
            o["ties_exterior"],
            o["ties_interior"],
            o["control_coordinates"],
        )
        k_e, k_i = o["check_targets_exterior"], o["check_targets_interior"]
        meas = PointList(
            k_e.ids + k_i.ids,
            np.vstack(
                [
                    apply_to_points(fn.T_world_base, k_e.xyz),
                    apply_to_points(fn.T_world_other, k_i.xyz),
                ]
            ),
        )
        pr = pair_points(meas, o["check_references"])
        return (pr.b - pr.a).reshape(-1)

    return residuals, x0, sig, err, groups


def _propagated_bound(scene, me, mi, ties_e, ties_i):
    """Expected free-network check point RMS, see :func:`_free_network_problem`.

    Returns the :class:`ResidualPropagation`, the realised share of each observation
    group (``J_g e_g`` with the true errors ``e_g`` known from the generator: which
    noise source made a seed good or bad) and the RMS difference between the linear
    prediction ``J e`` and the actual residuals (the free network is not exactly linear:
    its weights scale with the tie fit's a-posteriori sigma0), and, exactly, the RMS
    with each group's true errors removed.
    """
    from pyheracles.registration.checkpoints import propagate_residuals

    residuals, x0, sig, err, groups = _free_network_problem(scene, me, mi, ties_e, ties_i)
    prop = propagate_residuals(residuals, x0, sig, groups=groups)
    n = prop.n_points
    # exact (no linearisation): the RMS when one group's errors are removed (set to truth)
    without = {}
    for k, g in groups.items():
        x = x0.copy()
        x[g] -= err[g]
        without[k] = float(np.sqrt(np.sum(residuals(x) ** 2) / n))
    realised = {
        k: float(np.sqrt(np.sum((prop.jacobian[:, g] @ err[g]) ** 2) / n))
        for k, g in groups.items()
    }
    linear = prop.jacobian @ err  # residuals predicted from the true errors
    lin_err = float(np.sqrt(np.sum((linear - prop.residuals) ** 2) / n))
    return prop, realised, lin_err, without


def bench_church(seeds: tuple[int, ...] = tuple(range(10)), runs: int = 200) -> None:
    """Church: strategies, free-network RMS vs the noise bound, auto vs manual ties."""
    from pyheracles.registration.points import PointList
    from pyheracles.registration.strategies import (
        CloudMeasurements,
        block_adjustment,
        free_network,
        georeference_independent,
    )
    from pyheracles.registration.targets import measure_spheres
    from pyheracles.registration.tiepoints import find_tie_points
    from pyheracles.registration.transform import apply_to_cloud, apply_to_points
    from pyheracles.synthetic.church import make_church

    rng = np.random.default_rng(99)
    pooled = {"free": [], "bound": [], "auto": [], "manual": []}
    for seed in seeds:
        scene = make_church(rng=seed)
        ds = f"church_seed{seed}"
        me = measure_spheres(scene.exterior, scene.targets_exterior, 0.0725 * 0.8)
        mi = measure_spheres(scene.interior, scene.targets_interior, 0.0725)
        E = CloudMeasurements("exterior", me, True)
        I = CloudMeasurements("interior", mi, False)
        oracle = _church_rms(scene, me, mi, scene.T_world_exterior, scene.T_world_interior)
        ind = georeference_independent([E, I], scene.control)
        rms_ind = _church_rms(
            scene, me, mi, ind["exterior"].T_target_source, ind["interior"].T_target_source
        )
        fn = free_network(
            E, I, scene.manual_ties_exterior, scene.manual_ties_interior, scene.control
        )
        rms_free = _church_rms(scene, me, mi, fn.T_world_base, fn.T_world_other)
        e2 = PointList(
            me.ids + scene.manual_ties_exterior.ids,
            np.vstack([me.xyz, scene.manual_ties_exterior.xyz]),
            np.vstack([me.sigma, scene.manual_ties_exterior.sigma]),
        )
        i2 = PointList(
            mi.ids + scene.manual_ties_interior.ids,
            np.vstack([mi.xyz, scene.manual_ties_interior.xyz]),
            np.vstack([mi.sigma, scene.manual_ties_interior.sigma]),
        )
        blk = block_adjustment(
            [CloudMeasurements("exterior", e2, True), CloudMeasurements("interior", i2, False)],
            scene.control,
        )
        rms_blk = _church_rms(scene, me, mi, blk.transforms["exterior"], blk.transforms["interior"])
        with timer() as tb:
            prop, realised, lin_err, without = _propagated_bound(
                scene, me, mi, scene.manual_ties_exterior, scene.manual_ties_interior
            )
        bound = prop.expected_rms_3d
        q, dof, p_chi2 = prop.chi2_test()
        with timer() as tm:
            mc = _noise_bound(
                scene, me, mi, scene.manual_ties_exterior, scene.manual_ties_interior, runs, rng
            )
        emit(dataset=ds, metric="checkpoint_rms_3d_oracle_true_transforms_m", value=oracle)
        emit(dataset=ds, metric="checkpoint_rms_3d_independent_m", value=rms_ind)
        emit(dataset=ds, metric="checkpoint_rms_3d_block_m", value=rms_blk, sigma0=blk.sigma0)
        emit(
            dataset=ds,
            metric="free_network_rms_over_noise_bound",
            value=rms_free / bound,
            target="<=1.2",
            reached=rms_free / bound <= 1.2,
            free_network_rms_3d_m=rms_free,
            noise_bound_rms_3d_m=bound,
            bound="first-order propagation of all noise sources (_propagated_bound)",
            chi2_check_residuals=q,
            chi2_dof=dof,
            chi2_p_value=p_chi2,
            expected_rms_by_source_m=prop.expected_rms_by_group(),
            realised_rms_by_source_m=realised,
            linearisation_error_m=lin_err,
            rms_with_source_errors_removed_m=without,
            time_s=tb.s,
        )
        emit(
            dataset=ds,
            metric="free_network_noise_bound_monte_carlo_m",
            value=float(np.sqrt(np.mean(mc**2))),
            propagated_bound_m=bound,
            ratio_mc_over_propagated=float(np.sqrt(np.mean(mc**2))) / bound,
            fraction_of_noise_only_runs_with_larger_rms=float(np.mean(mc >= rms_free)),
            runs=runs,
            time_s=tm.s,
        )
        # automatic tie points: exterior made metric by its own georeferencing first
        T_ext = ind["exterior"].T_target_source
        ext_world = apply_to_cloud(scene.exterior, T_ext)
        with timer() as ta:
            auto = find_tie_points(scene.interior, ext_world)
        ties_e = PointList(auto.target.ids, apply_to_points(np.linalg.inv(T_ext), auto.target.xyz))
        ties_i = auto.source
        fa = free_network(E, I, ties_e, ties_i, scene.control)
        rms_auto = _church_rms(scene, me, mi, fa.T_world_base, fa.T_world_other)
        emit(
            dataset=ds,
            metric="auto_over_manual_checkpoint_rms",
            value=rms_auto / rms_free,
            target="<=2",
            reached=rms_auto / rms_free <= 2.0,
            auto_checkpoint_rms_3d_m=rms_auto,
            manual_checkpoint_rms_3d_m=rms_free,
            auto_tie_rms_3d_m=fa.tie.rms()["3d"],
            manual_tie_rms_3d_m=fn.tie.rms()["3d"],
            n_auto_ties=len(ties_i),
            n_manual_ties=len(scene.manual_ties_interior),
            n_panes=list(auto.n_panes),
            n_keypoints=list(auto.n_keypoints),
            n_putative=auto.n_putative,
            time_s=ta.s,
            points_per_s=(len(scene.interior) + len(scene.exterior)) / ta.s,
        )
        pooled["free"].append(rms_free**2)
        pooled["bound"].append(bound**2)
        pooled["auto"].append(rms_auto**2)
        pooled["manual"].append(rms_free**2)
    ratio = float(np.sqrt(np.mean(pooled["free"]) / np.mean(pooled["bound"])))
    per_seed = np.sqrt(np.array(pooled["free"]) / np.array(pooled["bound"]))
    emit(
        dataset="church_pooled",
        metric="free_network_rms_over_noise_bound",
        value=ratio,
        target="<=1.2",
        reached=ratio <= 1.2,
        seeds=list(seeds),
        per_seed=[round(float(r), 3) for r in per_seed],
        n_seeds_above_1_2=int((per_seed > 1.2).sum()),
    )
    ratio_a = float(np.sqrt(np.mean(pooled["auto"]) / np.mean(pooled["manual"])))
    emit(
        dataset="church_pooled",
        metric="auto_over_manual_checkpoint_rms",
        value=ratio_a,
        target="<=2",
        reached=ratio_a <= 2.0,
        seeds=list(seeds),
    )


def bench_church_seeds(n_seeds: int = 100) -> None:
    """Distribution of the free-network ratio over many generated churches (model check).

    Under a correct noise model the chi-square p-values of the check residuals are
    uniform on (0, 1) and the ratio RMS / propagated bound scatters around 1 with
    the spread of a 10-point RMS whose errors are correlated through the transforms.
    Prints one line per seed and a summary (quantiles, Kolmogorov-Smirnov test of
    uniformity of the p-values, where seed 0 falls).
    """
    from scipy.stats import kstest

    from pyheracles.registration.strategies import CloudMeasurements, free_network
    from pyheracles.registration.targets import measure_spheres
    from pyheracles.synthetic.church import make_church

    ratios, pvals = [], []
    with timer() as t:
        for seed in range(n_seeds):
            scene = make_church(rng=seed)
            me = measure_spheres(scene.exterior, scene.targets_exterior, 0.0725 * 0.8)
            mi = measure_spheres(scene.interior, scene.targets_interior, 0.0725)
            fn = free_network(
                CloudMeasurements("exterior", me, True),
                CloudMeasurements("interior", mi, False),
                scene.manual_ties_exterior,
                scene.manual_ties_interior,
                scene.control,
            )
            rms = _church_rms(scene, me, mi, fn.T_world_base, fn.T_world_other)
            prop, realised, *_ = _propagated_bound(
                scene, me, mi, scene.manual_ties_exterior, scene.manual_ties_interior
            )
            *_, pv = prop.chi2_test()
            ratios.append(rms / prop.expected_rms_3d)
            pvals.append(pv)
            emit(
                dataset=f"church_seed{seed}",
                metric="free_network_rms_over_noise_bound",
                value=ratios[-1],
                free_network_rms_3d_m=rms,
                noise_bound_rms_3d_m=prop.expected_rms_3d,
                chi2_p_value=pv,
                realised_rms_by_source_m=realised,
            )
    r = np.array(ratios)
    emit(
        dataset=f"church_seeds_0_{n_seeds - 1}",
        metric="free_network_ratio_distribution",
        value=float(np.sqrt(np.mean(r**2))),
        quantiles_5_25_50_75_95=np.quantile(r, [0.05, 0.25, 0.5, 0.75, 0.95]).round(3).tolist(),
        fraction_above_1_2=float(np.mean(r > 1.2)),
        seed0_ratio=float(r[0]),
        fraction_of_seeds_at_or_above_seed0=float(np.mean(r >= r[0])),
        ks_p_value_chi2_pvalues_uniform=float(kstest(pvals, "uniform").pvalue),
        fraction_chi2_p_below_0_05=float(np.mean(np.array(pvals) < 0.05)),
        time_s=t.s,
    )


def bench_bad_input() -> None:
    """Each bad input gives an InputError with a clear message (printed as JSON)."""
    import tempfile
    from pathlib import Path

    from pyheracles.errors import InputError
    from pyheracles.registration.icp import icp
    from pyheracles.registration.points import pair_points, read_points

    tmp = Path(tempfile.mkdtemp())
    (tmp / "dup.csv").write_text("id,X,Y,Z\nA,0,0,0\nA,1,0,0\nB,0,1,0\n")
    (tmp / "a.csv").write_text("id,X,Y,Z\nA,0,0,0\nB,1,0,0\nC,0,1,0\nD,0,0,1\n")
    (tmp / "b.csv").write_text("id,X,Y,Z\nA,0,0,0\nB,1,0,0\nC,0,1,0\nE,0,0,1\n")
    rng = np.random.default_rng(0)
    cube = rng.uniform(0, 1, (2000, 3))
    cases = {
        "fewer_than_3_pairs": lambda: estimate_similarity(np.zeros((2, 3)), np.ones((2, 3))),
        "duplicated_ids": lambda: read_points(tmp / "dup.csv"),
        "unmatched_ids": lambda: pair_points(
            read_points(tmp / "a.csv"), read_points(tmp / "b.csv")
        ),
        "collinear_points": lambda: estimate_similarity(
            np.outer(np.arange(5.0), [1, 2, 3]), np.outer(np.arange(5.0), [1, 2, 3]) + 1
        ),
        "clouds_do_not_overlap": lambda: icp(cube + 100.0, cube),
    }
    for name, fn in cases.items():
        try:
            fn()
            emit(dataset="bad_input", metric=name, value=False, message="no error raised")
        except InputError as exc:
            emit(dataset="bad_input", metric=name, value=True, message=str(exc))


# ----------------------------------------------------------------------------- church sweep
#: Targets of the church sweep (issue 14), metres.
SWEEP_RMS_TARGET_M = 0.015
SWEEP_SILENT_WRONG_M = 0.05


def _church_cloud(sim, name: str):
    """A cloud of a draw as ``heracles`` reads it from ``<name>.laz`` (0.1 mm, own frame)."""
    from pyheracles.cloud import PointCloud

    xyz = np.round(sim.clouds[name].xyz, 4)
    return PointCloud.from_world(xyz, source=f"{name}.laz")


def _sphere_centres(cloud, picks, ids, radius):
    """Sphere centres of the targets ``ids`` picked in ``cloud`` (skips those not found)."""
    from scipy.spatial import cKDTree

    from pyheracles.errors import HeraclesError
    from pyheracles.registration.points import PointList
    from pyheracles.registration.targets import measure_spheres

    keep = [i for i in ids if i in picks.ids]
    tree = cKDTree(cloud.xyz)
    out_ids, out_xyz, out_sig = [], [], []
    for k in keep:  # one fit per target (about ten)
        try:
            m = measure_spheres(cloud, picks.select([k]), radius, tree=tree)
        except HeraclesError:
            continue
        out_ids.append(k)
        out_xyz.append(m.xyz[0])
        out_sig.append(m.sigma[0])
    return PointList(
        tuple(out_ids), np.array(out_xyz).reshape(-1, 3), np.array(out_sig).reshape(-1, 3)
    )


def _checkpoint_rms(T_scene_cloud, measured, check) -> tuple[float | None, int]:
    """3D RMS of the check targets measured in a cloud and mapped by ``T_scene_cloud``."""
    from pyheracles.registration.checkpoints import check_points
    from pyheracles.registration.transform import apply_to_points

    ids = [i for i in measured.ids if i in check.ids]
    if not ids:
        return None, 0
    ref = check.select(ids).xyz
    got = apply_to_points(T_scene_cloud, measured.select(ids).xyz)
    return check_points(ref, got, ids).rms["3d"], len(ids)


def _georef_rigid(measured, control):
    """Rigid georeferencing of a cloud on its control targets (``heracles georef --rigid``)."""
    from pyheracles.registration.points import pair_points
    from pyheracles.registration.similarity import SimilarityParams, estimate_similarity

    pr = pair_points(measured, control, unmatched="ignore")
    res = estimate_similarity(
        pr.a,
        pr.b,
        SimilarityParams(with_scale=False, estimator="danish"),
        source_sigma=pr.sigma_a,
        target_sigma=pr.sigma_b,
        ids=pr.ids,
    )
    return res.T_target_source, len(pr.ids)


def _failure_mode(message: str) -> str:
    """A failure message without its numbers (to count modes over the draws)."""
    import re

    text = re.sub(r"\(.*?\)", "", message.split("\n")[0])
    text = re.sub(r"[-+]?\d+(\.\d+)?", "N", text)
    return " ".join(text.split())[:90]


def _auto_registration(sim, interior, exterior, model: str):
    """Today's ``heracles register interior.laz exterior.laz --auto [--model M]`` path."""
    from pyheracles.registration.similarity import SimilarityParams, estimate_similarity
    from pyheracles.registration.tiepoints import TiePointParams, find_tie_points

    sp = SimilarityParams(with_scale=model == "similarity", estimator="danish")
    tp = find_tie_points(
        interior,
        exterior,
        TiePointParams(pane_thickness_m=sim.params["pane_thickness_m"]),
        similarity=sp,
    )
    res = estimate_similarity(tp.source.xyz, tp.target.xyz, sp, ids=tp.source.ids)
    return tp, res


def _correct_ties(sim, tp) -> int:
    """Tie pairs whose two points are the same physical point (within 5 cm)."""
    from pyheracles.registration.transform import apply_to_points

    a = apply_to_points(sim.transforms["interior"], tp.source.xyz)
    b = apply_to_points(sim.transforms["exterior"], tp.target.xyz)
    return int(np.sum(np.linalg.norm(a - b, axis=1) < 0.05))


def church_sweep_draw(seed: int, model: str = "rigid") -> dict:
    """One draw of the church family: generate, run the automatic and the manual path, score.

    Automatic path: ``find_tie_points(interior, exterior)`` + the robust estimate of
    ``heracles register --auto`` (window pane corners; glass thickness known), then
    the interior check targets (sphere fits) mapped into the scene frame through the
    exterior's own georeferencing on its control targets; their 3D RMS against the
    surveyed check coordinates is the target metric.  Manual path (sanity check):
    the interior georeferenced rigidly on its own control targets.
    """
    from pyheracles.errors import HeraclesError
    from pyheracles.registration.transform import apply_to_points
    from pyheracles.synthetic.families import simulate

    with timer() as tg:
        sim = simulate("church", seed)
    p = sim.params
    ex = sim.extras
    radius = ex["target_radius_m"]
    interior, exterior = _church_cloud(sim, "interior"), _church_cloud(sim, "exterior")
    picks = ex["targets_measured"]
    check, control = ex["check"], ex["control"]
    int_check = [i for i in check.ids if i.startswith("CHK_I")]
    int_control = [i for i in control.ids if i.startswith("GCP_I")]
    ext_control = [i for i in control.ids if i.startswith("GCP_E")]
    rec = {
        "seed": seed,
        "exterior_kind": p["exterior_kind"],
        "n_interior_stations": p["n_interior_stations"],
        "n_exterior_stations": p["n_exterior_stations"] if p["exterior_kind"] == "tls" else 0,
        "n_cameras": p["n_cameras"] if p["exterior_kind"] == "photogrammetry" else 0,
        "detail_scans": p["detail_scans"],
        "wall_thickness_m": round(p["wall_thickness_m"], 3),
        "pane_thickness_m": round(p["pane_thickness_m"], 4),
        "pane_depth_ratio": round(p["pane_depth_ratio"], 3),
        "splay_m": round(p["splay_m"], 3),
        "n_windows": p["counts"]["windows"],
        "n_leaded": p["counts"]["leaded"],
        "shapes": {k: p["counts"][k] for k in ("rect", "round", "pointed")},
        "window_style": p["window_style"],
        "aisles": p["aisles"],
        "apse": p["apse"],
        "tower": p["tower"],
        "interior_levelled": p["interior_levelled"],
        "exterior_levelled": p["exterior_levelled"],
        "tilt_deg": [
            round(abs(v), 3) for f in ("interior_frame", "exterior_frame") for v in p[f][3:5]
        ],
        "points": {k: len(v) for k, v in sim.clouds.items()},
        "generate_time_s": round(tg.s, 2),
        "load_average_1min": round(os.getloadavg()[0], 2),
    }
    # reference measurements: sphere fits of the targets in each cloud's own frame
    with timer() as tm:
        meas_int = _sphere_centres(interior, picks["interior"], int_check + int_control, radius)
        meas_ext = _sphere_centres(exterior, picks["exterior"], ext_control, radius)
    rec["n_interior_check_measured"] = sum(i in meas_int.ids for i in int_check)
    # manual sphere-target path (works today): interior georeferenced on its own control
    try:
        T_si, n_ctrl = _georef_rigid(meas_int, control)
        rms_manual, _ = _checkpoint_rms(T_si, meas_int, check)
        rec["manual_control_points"] = n_ctrl
    except HeraclesError as exc:
        rms_manual = None
        rec["manual_error"] = str(exc).split("\n")[0]
    rec["manual_checkpoint_rms_3d_m"] = rms_manual
    rec["manual_time_s"] = round(tm.s, 2)
    # automatic path
    status, rms_auto = "flagged", None
    with timer() as ta:
        try:
            tp, res = _auto_registration(sim, interior, exterior, model)
        except HeraclesError as exc:
            tp = res = None
            rec["auto_error"] = str(exc).split("\n")[0]
            rec["auto_error_type"] = type(exc).__name__
            rec["failure_mode"] = _failure_mode(str(exc))
    rec["auto_time_s"] = round(ta.s, 2)
    if res is not None:
        T_ei = res.T_target_source
        rec.update(
            n_panes=list(tp.n_panes),
            n_keypoints=list(tp.n_keypoints),
            n_putative=tp.n_putative,
            n_ransac_inliers=tp.n_ransac_inliers,
            auto_details=tp.details,
            n_ties=len(tp.source),
            n_correct_ties=_correct_ties(sim, tp),
            tie_rms_3d_m=res.rms()["3d"],
            sigma0=res.sigma0,
        )
        # pure registration error at the true interior check centres (exterior frame)
        truth = ex["targets_true"]
        t_int = truth[(truth.frame == "interior") & truth.id.isin(int_check)]
        xyz = t_int[["X", "Y", "Z"]].to_numpy(float)
        err = apply_to_points(T_ei, xyz) - apply_to_points(ex["T_exterior_interior"], xyz)
        rec["registration_error_at_checks_m"] = float(np.sqrt(np.mean(np.sum(err**2, axis=1))))
        try:
            T_se, _ = _georef_rigid(meas_ext, control)
            rms_auto, n = _checkpoint_rms(T_se @ T_ei, meas_int, check)
            rec["n_check_points"] = n
        except HeraclesError as exc:
            rec["exterior_georef_error"] = str(exc).split("\n")[0]
        if rms_auto is None:
            status = "unscored"
        elif rms_auto <= SWEEP_RMS_TARGET_M:
            status = "ok"
        elif rms_auto <= SWEEP_SILENT_WRONG_M:
            status = "inaccurate"
            rec["failure_mode"] = "inaccurate transform (1.5-5 cm), no flag"
        else:
            status = "silent_wrong"
            rec["failure_mode"] = "wrong transform (> 5 cm) returned without a failure flag"
    rec["auto_checkpoint_rms_3d_m"] = rms_auto
    rec["auto_status"] = status
    rec["targets"] = {
        "auto_checkpoint_rms_le_1_5cm": status == "ok",
        "no_silent_wrong_transform": status != "silent_wrong",
        "manual_checkpoint_rms_le_1_5cm": rms_manual is not None
        and rms_manual <= SWEEP_RMS_TARGET_M,
    }
    rec["all_targets"] = all(rec["targets"].values())
    return rec


def bench_church_sweep(n: int = 30, first_seed: int = 0, model: str = "rigid") -> None:
    """``--sweep N``: today's automatic registration over N draws of the church family.

    One JSON line per draw (seed, drawn key parameters, metrics, pass/fail per target,
    times) and a summary line: share of draws meeting every target, per-target pass
    shares, shares of flagged failures and of silent wrong transforms, the failure
    modes with their seeds, the worst draw.  Outlier points are not excluded: the
    clouds go to the step code as they would from the files.  Sweeps run in parts
    (``--first-seed``) are summarised together with ``--summarise part1.jsonl ...``.
    """
    rows = []
    for seed in range(first_seed, first_seed + n):  # one draw after the other
        rec = church_sweep_draw(seed, model)
        rows.append(rec)
        emit(dataset=f"church_seed{seed}", metric="church_sweep_draw", **rec)
    church_sweep_summary(rows, first_seed, n, model)


def church_sweep_summary(rows: list[dict], first_seed: int, n: int, model: str) -> None:
    """The summary line of a church sweep from its per-draw records (see below)."""
    from collections import Counter

    status = Counter(r["auto_status"] for r in rows)
    modes: dict[str, list[int]] = {}
    for r in rows:
        if r.get("failure_mode"):
            modes.setdefault(r["failure_mode"], []).append(r["seed"])
    names = list(rows[0]["targets"]) if rows else []
    scored = [r for r in rows if r["auto_checkpoint_rms_3d_m"] is not None]
    worst = None
    if scored:
        # the worst outcome: a silent wrong transform, then the largest RMS
        rank = {"silent_wrong": 0, "inaccurate": 1, "ok": 2}
        worst = min(scored, key=lambda r: (rank[r["auto_status"]], -r["auto_checkpoint_rms_3d_m"]))
    elif rows:  # no transform returned at all: the first flagged draw stands for them
        worst = rows[0]
    manual = [r for r in rows if r["manual_checkpoint_rms_3d_m"] is not None]
    manual_worst = max(manual, key=lambda r: r["manual_checkpoint_rms_3d_m"]) if manual else None
    emit(
        dataset=f"church_seeds_{first_seed}_{first_seed + n - 1}",
        metric="church_sweep_summary",
        value=float(np.mean([r["all_targets"] for r in rows])) if rows else None,
        n_draws=len(rows),
        model=model,
        share_all_targets=float(np.mean([r["all_targets"] for r in rows])) if rows else None,
        share_per_target={k: float(np.mean([r["targets"][k] for r in rows])) for k in names},
        share_auto_within_1_5cm=status["ok"] / max(len(rows), 1),
        share_flagged_failures=status["flagged"] / max(len(rows), 1),
        share_silent_wrong=status["silent_wrong"] / max(len(rows), 1),
        share_inaccurate_unflagged=status["inaccurate"] / max(len(rows), 1),
        share_unscored=status["unscored"] / max(len(rows), 1),
        auto_status_counts=dict(status),
        failure_modes={
            k: {"count": len(v), "seeds": v}
            for k, v in sorted(modes.items(), key=lambda kv: -len(kv[1]))
        },
        auto_rms_median_m=float(np.median([r["auto_checkpoint_rms_3d_m"] for r in scored]))
        if scored
        else None,
        manual_rms_median_m=float(
            np.median(
                [
                    r["manual_checkpoint_rms_3d_m"]
                    for r in rows
                    if r["manual_checkpoint_rms_3d_m"] is not None
                ]
            )
        )
        if any(r["manual_checkpoint_rms_3d_m"] is not None for r in rows)
        else None,
        worst_seed=worst["seed"] if worst else None,
        worst_note=None if scored else "no draw returned a transform: all failed with a flag",
        manual_worst_seed=manual_worst["seed"] if manual_worst else None,
        manual_worst_rms_m=manual_worst["manual_checkpoint_rms_3d_m"] if manual_worst else None,
        worst_status=worst["auto_status"] if worst else None,
        worst_rms_m=worst["auto_checkpoint_rms_3d_m"] if worst else None,
        generate_time_s_total=float(sum(r["generate_time_s"] for r in rows)),
        generate_time_s_mean=float(np.mean([r["generate_time_s"] for r in rows])) if rows else None,
        auto_time_s_mean=float(np.mean([r["auto_time_s"] for r in rows])) if rows else None,
        rms_target_m=SWEEP_RMS_TARGET_M,
        silent_wrong_threshold_m=SWEEP_SILENT_WRONG_M,
    )


def church_pane_coverage(sim, cell_m: float = 0.05) -> dict:
    """What each cloud offers a pane detector: glass points and 5 cm cell fill per window.

    From the reference labels (not the step code): for every window light, the
    points of its glass in each cloud (outliers excluded) and the share of the
    light's ``cell_m`` cells that hold one, which
    :func:`~pyheracles.registration.tiepoints.find_tie_points` requires to be at least
    ``min_fill`` (0.8).  Returns per cloud the windows, the median glass points and
    cell fill, and how many lights reach 0.8.
    """
    from shapely import contains_xy
    from shapely.geometry import Polygon

    scene = sim.scene
    pane = [k for k, v in scene.part_names.items() if v == "pane"]
    windows = [o for o in scene.objects if o["class"] == "window"]
    out = {}
    for name, res in sim.clouds.items():
        T = sim.transforms[name]
        m = np.isin(res.part, pane) & ~res.outlier
        xyz = res.xyz[m] @ T[:3, :3].T + T[:3, 3]
        inst = res.instance[m]
        n_pts, fill = [], []
        for w in windows:  # tens of lights
            ring = np.asarray(w["outline_m"])
            c = np.asarray(w["plane"]["point"])
            nrm = np.asarray(w["plane"]["normal"])
            h = np.cross([0.0, 0.0, 1.0], nrm)
            h /= np.linalg.norm(h)
            uv = np.column_stack([(ring - c) @ h, ring[:, 2] - c[2]])
            pts = xyz[inst == w["instance"]]
            q = np.column_stack([(pts - c) @ h, pts[:, 2] - c[2]])
            lo, hi = uv.min(0), uv.max(0)
            gx = np.arange(lo[0] + cell_m / 2, hi[0], cell_m)
            gy = np.arange(lo[1] + cell_m / 2, hi[1], cell_m)
            G = np.stack(np.meshgrid(gx, gy), -1).reshape(-1, 2)
            inside = contains_xy(Polygon(uv), G[:, 0], G[:, 1])
            cells = set(map(tuple, np.floor((q - lo) / cell_m).astype(int)))
            gi = {tuple(v) for v in np.floor((G[inside] - lo) / cell_m).astype(int)}
            n_pts.append(len(pts))
            fill.append(len(cells & gi) / max(len(gi), 1))
        out[name] = {
            "windows": len(windows),
            "median_glass_points": float(np.median(n_pts)) if n_pts else 0.0,
            "median_cell_fill": float(np.median(fill)) if fill else 0.0,
            "lights_fill_ge_0_8": int(np.sum(np.array(fill) >= 0.8)),
        }
    return out


def bench_church_panes(n: int = 6, first_seed: int = 0) -> None:
    """Glass coverage of the window lights in each cloud of N church draws (diagnostic)."""
    from pyheracles.synthetic.families import simulate

    for seed in range(first_seed, first_seed + n):
        sim = simulate("church", seed)
        p = sim.params
        emit(
            dataset=f"church_seed{seed}",
            metric="church_pane_coverage",
            exterior_kind=p["exterior_kind"],
            detail_scans=p["detail_scans"],
            interior_step_deg=p["interior_step_effective_deg"],
            exterior_step_deg=p["exterior_step_effective_deg"],
            n_leaded=p["counts"]["leaded"],
            **church_pane_coverage(sim),
        )


def _parse_args(argv: list[str]):
    import argparse

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("sections", nargs="*", help=f"sections to run: {', '.join(SECTIONS)}")
    ap.add_argument(
        "--sweep",
        type=int,
        metavar="N",
        help="run the church family sweep over N draws instead of the sections",
    )
    ap.add_argument("--first-seed", type=int, default=0, metavar="S", help="first seed (0)")
    ap.add_argument(
        "--summarise",
        nargs="+",
        metavar="JSONL",
        help="print the sweep summary of the draw lines in these files (sweeps run in parts)",
    )
    ap.add_argument(
        "--model",
        default="rigid",
        choices=("rigid", "similarity"),
        help="transform model of the automatic registration (rigid, as in the README)",
    )
    return ap.parse_args(argv)


SECTIONS = {
    "montecarlo": bench_montecarlo,
    "badinput": bench_bad_input,
    "church": bench_church,
    "churchseeds": bench_church_seeds,
    "churchpanes": bench_church_panes,
    "icp": bench_icp,
    "bunny": bench_bunny,
}


def main() -> None:
    """Run the sections named on the command line, a church sweep, or its summary."""
    args = _parse_args(sys.argv[1:])
    if args.summarise:
        import json

        recs = []
        for path in args.summarise:
            with open(path) as fh:
                recs += [json.loads(x) for x in fh if '"church_sweep_draw"' in x]
        recs.sort(key=lambda r: r["seed"])
        for r in recs:
            emit(**r)
        seeds = [r["seed"] for r in recs]
        church_sweep_summary(recs, min(seeds), max(seeds) - min(seeds) + 1, args.model)
    elif args.sweep is not None:
        bench_church_sweep(args.sweep, args.first_seed, args.model)
    else:
        for name in args.sections or list(SECTIONS):
            SECTIONS[name]()


if __name__ == "__main__":
    interruptible(main)
