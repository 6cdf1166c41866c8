"""The settings and the result of matching the glazed openings of two clouds
(:func:`~pyheracles.registration.pane_matching.match_openings`, whose module docstring
describes the stages these settings steer)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from pyheracles.registration.pane_icp import PaneICPParams

__all__ = ["MatchParams", "OpeningMatch"]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class MatchParams:
    """Parameters of :func:`match_openings` (metres and degrees).

    Attributes
    ----------
    size_tolerance_m, size_tolerance_rel
        Largest width / height difference of two openings that may match:
        ``size_tolerance_m + size_tolerance_rel * size``.
    distance_tolerance_m
        Largest difference of two centre-to-centre distances (rigid invariant); the
        centres come from outlines seen in part (a sill hidden from below), hence
        the decimetres.
    angle_tolerance_deg
        Largest difference of normal angles (rigid invariant).
    opposite_sides
        The clouds see the panes from opposite sides (exterior vs interior).
    hypotheses
        Best cliques refined by the fine fit.
    centre_gate_m
        An opening is explained by a transform when its mapped centre lies within this
        distance of its partner's (and the normals agree).
    fine_gates_m
        Outline correspondence distances of the fine fit, coarse to fine.
    fine_tolerance_m
        An opening's outline agrees when the median point-to-line distance is below it.
    min_openings
        Fewest matched openings of one size whose outlines agree for a solution
        (agreeing outlines of another size add tie points, not evidence).
    ambiguity_ratio
        A runner-up with at least this share of the best's agreeing openings (and at
        least ``min_openings``) makes the solution ambiguous.
    max_outline_points
        Outline points per opening used in the fine fit (regular subsample).
    min_outline_share
        Two outlines are compared only when at least this share of one of them (the one
        lying on the other: a partial outline on a whole one) lies within twice the
        finest fine gate of the other.  True poses give 0.3-0.6 where both outlines are
        partial (church draw 20), and so do wrong poses onto windows of nearly one size
        (a 180 deg turn of a synthetic church with sparse, scattered exterior outlines,
        accepted 12 m off): the share alone does not tell them apart.
    coarse_gate_m
        For a recess ICP solution (its pose verified by raw reveal points), outlines that
        cannot be compared within twice the finest fine gate (less than
        ``min_outline_share`` of either lies that close to the other) but can within
        this distance are unverified, not contradicting: a sparse exterior outline seen
        from far below sits a few centimetres off its partner's under the true pose
        (church draw 4).  Outline solutions keep the strict test (a one-bay shift onto
        windows of nearly one size leaves outlines a few centimetres apart too).
    min_outline_spread
        An outline comparison verifies an opening only when its in-plane normals fix
        both directions: the smaller eigenvalue of their 2 x 2 second-moment matrix is
        at least this (about 0.5 for a square, 0.15 for a 1 x 3 light, 0 for two jambs);
        otherwise the opening is unverified (neither agrees nor contradicts).
    depth_weight, reveal_depth_weight
        Weight (in outline points) of an opening's pane depth in the fine fit; the second
        for a depth from where a reveal ends (a sparse reveal may stop short of the
        glass) when other pairs have depths from glass points on both sides.
    max_contradiction
        A hypothesis is refused when more openings contradict it (mapped onto a
        partner whose outline disagrees) than this share of those that agree.
    max_tilt_deg
        Largest angle between the vertical of the two clouds (both roughly levelled):
        hypotheses turning the building over are refused.
    up
        Vertical direction in both clouds.
    recess_icp
        Parameters of the recess ICP (:class:`~pyheracles.registration.pane_icp.PaneICPParams`);
        ``None`` turns it off (outline solutions only).
    recess_depth_weight
        Weight (in points) of each opening's pane-depth row in the recess ICP: small,
        the detected pane depths may be off by a centimetre or two (sparse glass, a
        reveal ending short), so they only hold the depth where no reveal of another
        wall direction does.
    min_translation_spread
        Smallest eigenvalue of the summed normal moments of the openings verified by
        their raw points (:attr:`~pyheracles.registration.pane_icp.PaneICPResult.normal_moment`,
        a trace of one per opening) for the recess solution to be taken: the weakest
        translation must be fixed by at least this share of one opening's reveal
        points (0 for reveals of one wall direction without splays).  A weaker
        translation still stands when the raw reveal points hold it: the recess ICP
        without the pane-depth rows, started ``restart_m`` off along it both ways,
        returns within ``max_basin_m`` (the openings not verified on their own, too
        sparse for a verdict, still pull; church draw 46).  Pane depths alone never fix
        it: a depth from a reveal ending short errs by decimetres, and photogrammetric
        depths scatter by a centimetre, which lets the pose turn (church draw 35: seven
        depths agreeing within 1.5 cm, the pose 1.2 cm off).
    min_outline_openings
        Fewest agreeing outlines of openings of one size for a solution that the raw
        recess points do not verify (three partial outlines agreed under a pose 7 m off
        in church draw 43; the outline solutions of the church sweep rest on 11-18).
    retry_tolerance_factor
        When no trustworthy match is found, the search is made once more with
        ``distance_tolerance_m`` and ``centre_gate_m`` times this, and its solution is
        taken only when the raw recess points verify it: an exterior TLS seeing deep
        reveals from below puts opening centres 0.2-0.5 m off (sills hidden, no glass
        return so the pane depth from where the reveals end; church draws 42 and 43,
        and 9 on the simulator before the per-ray noise, registered within 3 mm this
        way).  1: no second search.
    max_basin_m
        The recess solution is taken only when the minima reached from displaced starts
        lie within this RMS distance of it over the matched pane centres
        (:attr:`~pyheracles.registration.pane_icp.PaneICPResult.basin_m`): a pose the
        reveals do not fix, or one pulled aside by a splayed reveal, is not unique.
    max_loose_turn_m
        A recess solution whose tie points come from ``min_openings`` openings is
        taken only when the reveals of those verified by their raw points fix every
        turn about their centre to this where the source cloud's openings are
        (:func:`~pyheracles.registration.pane_icp.loose_turn`: each opening one
        observation, the recess ICP's RMS its error; the translations have their own
        test, ``min_translation_spread``).  The restarts of ``max_basin_m`` displace
        the translation only, and a turn moving an opening along its own pane normal,
        or about the line through the openings, is held by the pane depths alone
        (church draw 9: returned 15.5 cm wrong, loose by 2.5 cm 16 m from its 3
        openings; draw 24, 3 openings on one wall: 4.6 cm wrong, loose by 7.4 cm;
        draw 46: right, 0.9 cm).  Solutions on more openings are not re-examined; a loose
        solution still competes with the others (ambiguity, ranking) and is refused
        only when it wins, and no looser search follows.
    """

    size_tolerance_m: float = 0.1
    size_tolerance_rel: float = 0.1
    distance_tolerance_m: float = 0.25
    angle_tolerance_deg: float = 8.0
    opposite_sides: bool = True
    hypotheses: int = 4
    centre_gate_m: float = 0.3
    fine_gates_m: tuple[float, ...] = (0.08, 0.04, 0.02, 0.015)
    fine_tolerance_m: float = 0.012
    min_openings: int = 3
    ambiguity_ratio: float = 0.8
    max_outline_points: int = 400
    min_outline_share: float = 0.3
    coarse_gate_m: float = 0.1
    min_outline_spread: float = 0.05
    depth_weight: float = 30.0
    reveal_depth_weight: float = 3.0
    max_tilt_deg: float = 10.0
    max_contradiction: float = 0.5
    up: tuple[float, float, float] = (0.0, 0.0, 1.0)
    recess_icp: PaneICPParams | None = field(default_factory=PaneICPParams)
    recess_depth_weight: float = 1.0
    min_translation_spread: float = 0.1
    min_outline_openings: int = 4
    retry_tolerance_factor: float = 2.0
    max_basin_m: float = 0.005
    max_loose_turn_m: float = 0.015


@dataclass(frozen=True, eq=False)
class OpeningMatch:
    """Result of :func:`match_openings` (``T_target_source`` maps source to target).

    Attributes
    ----------
    T_target_source
        Rigid transform from the fine fit.
    pairs
        ``(K, 2)`` indices of the matched openings (source, target) giving tie points:
        those whose outlines agree, or for a recess solution those its raw points
        verify (when at least ``min_openings``).
    outline_rms
        ``(K,)`` RMS point-to-line distance of each matched outline, metres.
    local
        ``(K, 4, 4)`` local transforms (the global one corrected in the pane plane and
        along its normal by the opening's own outline and depth).
    n_candidates, n_consistent
        Candidate pairs and the size of the best clique.
    runner_up
        Agreeing openings of the best different hypothesis (0 if none).
    n_contradicted
        Openings mapped onto a partner whose outline disagrees (wrong detections).
    n_mirrored
        Consistent arrangements refused because only a reflection maps them.
    method
        ``"outlines"`` (outline least squares) or ``"recess_icp"`` (refined on the raw
        recess points, see :mod:`~pyheracles.registration.pane_icp`).
    n_recess_verified
        Matched openings verified by their raw recess points (recess solution).
    recess_rms_m
        Weighted point-to-plane RMS of the recess ICP's last step (``nan``: outlines).
    recess_basin_m
        Spread of the recess ICP's minima from displaced starts (``nan``: outlines).
    """

    T_target_source: Array
    pairs: NDArray[np.int_]
    outline_rms: Array
    local: Array
    n_candidates: int
    n_consistent: int
    runner_up: int
    n_contradicted: int = 0
    n_mirrored: int = 0
    method: str = "outlines"
    n_recess_verified: int = 0
    recess_rms_m: float = float("nan")
    recess_basin_m: float = float("nan")
