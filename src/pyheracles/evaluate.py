"""Scores of a segmentation against reference labels.

Per object (Murtiyoso 2020, tables 5.1 and 5.2): precision, recall, F1 score
and the share of the object's points left unclassified, one row per reference
object plus mean and median rows.  Predicted objects are paired with reference
objects either by a shared key (both carry the GIS feature id) or by maximum
overlap (a one-to-one assignment maximising the number of shared points).
Ground: precision / recall and the errors of Sithole & Vosselman (2004).  And
the reference of the Delft AHN3 benchmark: per building polygon, the class-6
points inside it or within a buffer, the nearest polygon winning.

Definitions, for a reference object *R* and its matched prediction *P* (sets
of point indices)::

    TP = |R & P|    FP = |P - R|    FN = |R - P|
    precision = TP / (TP + FP)      recall = TP / (TP + FN)
    F1 = 2 precision recall / (precision + recall)
    unclassified = 100 |R & {points in no predicted object}| / |R|

A reference object without a match gets recall 0, F1 0, precision undefined
(NaN).  Reference objects with no points (a demolished building still in the
GIS) are listed with NaN scores and left out of the mean and median.
"""

from __future__ import annotations

from collections.abc import Hashable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd
import shapely
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import linear_sum_assignment

from pyheracles.errors import InputError

__all__ = [
    "MATCH_METHODS",
    "ObjectEvaluation",
    "evaluate_by_feature",
    "evaluate_objects",
    "ground_scores",
    "reference_from_polygons",
]

#: How predicted objects are paired with reference objects.
MATCH_METHODS = ("overlap", "key")

SCORE_COLUMNS = ["precision", "recall", "f1", "unclassified_pct"]


@dataclass(frozen=True, eq=False)
class ObjectEvaluation:
    """Per-object scores of a segmentation.

    Attributes
    ----------
    objects
        One row per reference object: ``reference`` (instance id), ``key``
        (with key matching), ``predicted`` (matched predicted instance ids, a
        tuple, empty if none), ``n_reference``, ``n_predicted``, ``tp``, ``fp``,
        ``fn``, ``n_unclassified``, ``precision``, ``recall``, ``f1``,
        ``unclassified_pct``; extra columns of the reference table when given.
    unmatched
        Predicted objects paired with no reference object: ``predicted``,
        ``n_points``, ``key``.
    match
        ``"overlap"`` or ``"key"``.
    """

    objects: pd.DataFrame
    unmatched: pd.DataFrame
    match: str

    def summary(self, by: str | None = None) -> pd.DataFrame:
        """Mean and median of the scores over the reference objects that have points.

        Parameters
        ----------
        by
            A column of :attr:`objects` (e.g. ``"layer"``) to summarise per
            group; the index is then ``(group, "mean" | "median")``.
        """
        scored = self.objects[self.objects["n_reference"] > 0]
        if by is not None:
            if by not in scored.columns:
                raise InputError(
                    f"cannot summarise by {by!r}: no such column",
                    hint=f"choose one of {', '.join(map(str, self.objects.columns))}",
                )
            parts = {g: _mean_median(part) for g, part in scored.groupby(by, sort=False)}
            if not parts:
                return _mean_median(scored).iloc[:0]
            return pd.concat(parts, names=[by, "statistic"])
        return _mean_median(scored)

    def table(self) -> pd.DataFrame:
        """Thesis-style table: a row per object, then the ``mean`` and ``median`` rows.

        The first column ``object`` holds the reference key (or instance id),
        then ``mean`` and ``median``.
        """
        label = self.objects["key"] if "key" in self.objects else self.objects["reference"]
        rows = self.objects.assign(object=label.astype(str))
        cols = [
            "object",
            "reference",
            "n_reference",
            "n_predicted",
            "tp",
            "fp",
            "fn",
            *SCORE_COLUMNS,
        ]
        for extra in ("name", "layer"):  # descriptive columns of the reference table
            if extra in rows:
                cols.insert(1, extra)
        body = rows[cols]
        summary = self.summary().reset_index(names="object")
        out = pd.concat([body, summary], ignore_index=True)
        counts = ["reference", "n_reference", "n_predicted", "tp", "fp", "fn"]
        return out.astype({c: "Int64" for c in counts})  # integers with blank summary cells

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary: objects, summary, unmatched, totals."""

        def records(df: pd.DataFrame) -> list[dict[str, Any]]:
            out = df.copy()
            for col in out.columns:
                if out[col].dtype == object:
                    out[col] = out[col].map(
                        lambda v: list(v) if isinstance(v, tuple) else v  # tuples -> lists
                    )
            return [
                {k: (None if _isnan(v) else _py(v)) for k, v in r.items()}
                for r in out.to_dict(orient="records")
            ]

        def stats(df: pd.DataFrame) -> dict[str, Any]:
            return {
                name: {k: (None if _isnan(v) else float(v)) for k, v in row.items()}
                for name, row in df.iterrows()
            }

        out_layers = {}
        if "layer" in self.objects.columns:
            per = self.summary(by="layer")
            for layer in per.index.get_level_values(0).unique():
                out_layers[str(layer)] = stats(per.loc[layer])
        return {
            "match": self.match,
            "objects": records(self.objects),
            "summary": stats(self.summary()),
            "summary_by_layer": out_layers,
            "unmatched_predicted": records(self.unmatched),
            "totals": self.totals(),
        }

    def totals(self) -> dict[str, int]:
        """Point totals over all reference objects (micro counts)."""
        o = self.objects
        return {
            "n_reference_objects": int((o["n_reference"] > 0).sum()),
            "n_matched": int((o["tp"] > 0).sum()),
            "n_unmatched_predicted": len(self.unmatched),
            "tp": int(o["tp"].sum()),
            "fp": int(o["fp"].sum()),
            "fn": int(o["fn"].sum()),
            "unclassified": int(o["n_unclassified"].sum()),
        }


def _mean_median(scored: pd.DataFrame) -> pd.DataFrame:
    rows = {
        "mean": scored[SCORE_COLUMNS].mean(skipna=True),
        "median": scored[SCORE_COLUMNS].median(skipna=True),
    }
    return pd.DataFrame(rows).T


def _isnan(v: Any) -> bool:
    return isinstance(v, float) and np.isnan(v)


def _py(v: Any) -> Any:
    return v.item() if isinstance(v, np.generic) else v


def _labels(values: ArrayLike, what: str) -> NDArray[np.int64]:
    arr = np.asarray(values)
    if arr.ndim != 1:
        raise InputError(f"{what} labels must be one-dimensional, got shape {arr.shape}")
    if arr.size and not np.issubdtype(arr.dtype, np.integer):
        if not np.all(np.isfinite(arr)) or np.any(arr != np.round(arr)):
            raise InputError(f"{what} labels must be integers (0 = none)")
    arr = arr.astype(np.int64)
    if arr.size and arr.min() < 0:
        raise InputError(f"{what} labels must be >= 0 (0 = none), found {arr.min()}")
    return arr


def _key_map(keys: Mapping[int, Hashable] | pd.Series | None, what: str) -> dict[int, Hashable]:
    if keys is None:
        raise InputError(
            f"matching by key needs the {what} keys",
            hint=f"pass {what}_keys (instance id -> key), e.g. from the objects table",
        )
    return {
        int(k): v for k, v in keys.items() if not (np.isscalar(v) and pd.isna(v)) and v is not None
    }


def _contingency(
    ref: NDArray[np.int64], pred: NDArray[np.int64]
) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]]:
    """Sparse overlap counts of (reference, predicted) pairs, both non-zero."""
    both = (ref > 0) & (pred > 0)
    if not both.any():
        empty = np.zeros(0, np.int64)
        return empty, empty, empty
    r, p = ref[both], pred[both]
    code = r * (int(p.max()) + 1) + p
    uniq, cnt = np.unique(code, return_counts=True)
    return uniq // (int(p.max()) + 1), uniq % (int(p.max()) + 1), cnt


def evaluate_objects(
    predicted: ArrayLike,
    reference: ArrayLike,
    *,
    match: str = "overlap",
    predicted_keys: Mapping[int, Hashable] | pd.Series | None = None,
    reference_keys: Mapping[int, Hashable] | pd.Series | None = None,
    reference_objects: pd.DataFrame | None = None,
) -> ObjectEvaluation:
    """Per-object precision, recall, F1 and % unclassified of a segmentation.

    Parameters
    ----------
    predicted, reference
        ``(N,)`` integer object id of every point (0 = in no object), aligned
        point by point (same cloud, same order).
    match
        ``"overlap"``: pair objects one-to-one so that the total number of
        shared points is maximal (Hungarian assignment on the overlap counts;
        pairs sharing no point are never made).  ``"key"``: pair objects that
        carry the same key (e.g. the GIS feature id); several predicted objects
        with one key are merged into one prediction.
    predicted_keys, reference_keys
        Instance id -> key, required with ``match="key"``.
    reference_objects
        Optional table with an ``instance`` column listing every reference
        object, also those without points (they get NaN scores); its other
        columns (``name``, ``layer`` ...) are copied into the result.

    Returns
    -------
    ObjectEvaluation
        Per-object rows, unmatched predictions; ``.table()`` adds the mean and
        median rows.

    Raises
    ------
    InputError
        Arrays of different length, negative or non-integer labels, unknown
        ``match``, missing keys.

    Examples
    --------
    >>> ev = evaluate_objects([1, 1, 1, 0], [1, 1, 0, 0])
    >>> ev.objects[["precision", "recall", "f1"]].round(3).values.tolist()
    [[0.667, 1.0, 0.8]]
    """
    if match not in MATCH_METHODS:
        raise InputError(f"unknown match method {match!r}", hint=f"use one of {MATCH_METHODS}")
    pred = _labels(predicted, "predicted")
    ref = _labels(reference, "reference")
    if len(pred) != len(ref):
        raise InputError(
            f"predicted and reference labels differ in length ({len(pred)} vs {len(ref)})",
            hint="both must label the same points in the same order",
        )

    if match == "key":
        pkeys = _key_map(predicted_keys, "predicted")
        rkeys = _key_map(reference_keys, "reference")
        seen: dict[Hashable, int] = {}
        for inst, key in rkeys.items():
            if key in seen:
                raise InputError(
                    f"reference objects {seen[key]} and {inst} share the key {key!r}",
                    hint="match by a key that is unique in the reference (e.g. the feature id)",
                )
            seen[key] = inst
        # merge predicted instances by key: code every key to one group id; predicted
        # objects without a key stay objects of their own (never paired)
        key_ids: dict[Hashable, int] = {}
        for key in list(rkeys.values()) + list(pkeys.values()):
            key_ids.setdefault(key, len(key_ids) + 1)
        for inst in np.unique(pred[pred > 0]).tolist():
            if inst not in pkeys:
                pkeys[inst] = ("<no key>", inst)
                key_ids[pkeys[inst]] = len(key_ids) + 1
        lut = np.zeros(int(pred.max(initial=0)) + 1, np.int64)
        for inst, key in pkeys.items():
            if inst < len(lut):
                lut[inst] = key_ids[key]
        pred_group = lut[pred]
    else:
        pred_group = pred

    n_pred_pts = np.bincount(pred_group, minlength=1)
    n_ref_pts = np.bincount(ref, minlength=1)
    unclassified = np.bincount(ref[pred == 0], minlength=len(n_ref_pts))

    # reference objects to report
    ref_ids = np.flatnonzero(n_ref_pts[1:]) + 1
    extra = None
    if reference_objects is not None:
        if "instance" not in reference_objects:
            raise InputError("the reference objects table has no 'instance' column")
        listed = reference_objects["instance"].to_numpy().astype(np.int64)
        ref_ids = np.union1d(ref_ids, listed)
        extra = reference_objects.drop_duplicates("instance").set_index("instance")

    r_idx, p_idx, cnt = _contingency(ref, pred_group)
    pairs: dict[int, tuple[int, int]] = {}  # reference -> (predicted group, tp)
    if match == "key":
        for r, p, c in zip(r_idx, p_idx, cnt, strict=True):
            if r in rkeys and key_ids[rkeys[r]] == p:
                pairs[int(r)] = (int(p), int(c))
        # matched by key but sharing no point: still a pair (tp = 0)
        for r, key in rkeys.items():
            p = key_ids[key]
            if r not in pairs and p < len(n_pred_pts) and n_pred_pts[p] > 0:
                pairs[r] = (p, 0)
    elif len(cnt):
        ru, r_pos = np.unique(r_idx, return_inverse=True)
        pu, p_pos = np.unique(p_idx, return_inverse=True)
        gain = np.zeros((len(ru), len(pu)))
        gain[r_pos, p_pos] = cnt
        rows, cols = linear_sum_assignment(gain, maximize=True)
        for i, j in zip(rows, cols, strict=True):
            if gain[i, j] > 0:
                pairs[int(ru[i])] = (int(pu[j]), int(gain[i, j]))

    group_members: dict[int, tuple[int, ...]] = {}
    if match == "key":
        for inst, key in sorted(pkeys.items()):
            group_members[key_ids[key]] = (*group_members.get(key_ids[key], ()), inst)
    records = []
    for r in ref_ids:
        n_r = int(n_ref_pts[r]) if r < len(n_ref_pts) else 0
        p, tp = pairs.get(int(r), (0, 0))
        n_p = int(n_pred_pts[p]) if p else 0
        fp, fn = n_p - tp, n_r - tp
        prec = tp / n_p if n_p else np.nan
        rec = tp / n_r if n_r else np.nan
        if n_r == 0:
            f1 = np.nan
        elif tp == 0:
            f1 = 0.0
        else:
            f1 = 2 * prec * rec / (prec + rec)
        uncl = int(unclassified[r]) if r < len(unclassified) else 0
        row: dict[str, Any] = {"reference": int(r)}
        if match == "key":
            row["key"] = rkeys.get(int(r))
            row["predicted"] = group_members.get(p, ()) if p else ()
        else:
            row["predicted"] = (p,) if p else ()
        row.update(
            n_reference=n_r,
            n_predicted=n_p,
            tp=tp,
            fp=fp,
            fn=fn,
            n_unclassified=uncl,
            precision=prec,
            recall=rec,
            f1=f1,
            unclassified_pct=100.0 * uncl / n_r if n_r else np.nan,
        )
        if extra is not None and r in extra.index:
            for col, val in extra.loc[r].items():
                if col not in row and col != "geometry":
                    row[col] = val
        records.append(row)
    objects = pd.DataFrame.from_records(records)
    if objects.empty:
        objects = pd.DataFrame(
            columns=["reference", "predicted", "n_reference", "n_predicted", "tp", "fp", "fn",
                     "n_unclassified", *SCORE_COLUMNS]
        )  # fmt: skip

    matched = {p for p, _ in pairs.values()}
    pred_ids = np.flatnonzero(n_pred_pts[1:]) + 1
    un = [int(p) for p in pred_ids if int(p) not in matched]
    unmatched = pd.DataFrame(
        {
            "predicted": [group_members.get(p, (p,)) if match == "key" else (p,) for p in un],
            "n_points": [int(n_pred_pts[p]) for p in un],
        }
    )
    if match == "key":
        inv = {v: k for k, v in key_ids.items()}
        unmatched["key"] = [None if isinstance(inv.get(p), tuple) else inv.get(p) for p in un]
    return ObjectEvaluation(objects=objects, unmatched=unmatched, match=match)


def ground_scores(predicted: ArrayLike, reference: ArrayLike) -> dict[str, float]:
    """Precision, recall and the filter errors of a ground classification.

    Parameters
    ----------
    predicted, reference
        ``(N,)`` boolean ground masks of the same points.

    Returns
    -------
    dict
        ``tp``, ``fp``, ``fn``, ``tn`` (point counts, ground = positive),
        ``precision``, ``recall``, ``f1``; the errors of Sithole & Vosselman
        (2004) in percent: ``type_i`` (ground rejected), ``type_ii`` (objects
        accepted as ground), ``total``; and Cohen's ``kappa``.  Ratios with a
        zero denominator are NaN.

    Examples
    --------
    >>> s = ground_scores([True, True, False, False], [True, False, False, False])
    >>> s["precision"], s["recall"]
    (0.5, 1.0)
    """
    p = np.asarray(predicted)
    r = np.asarray(reference)
    if p.shape != r.shape or p.ndim != 1:
        raise InputError(
            f"ground masks must be 1-D and of equal length, got {p.shape} and {r.shape}"
        )
    if p.dtype != bool or r.dtype != bool:
        raise InputError("ground masks must be boolean arrays")
    tp = int(np.count_nonzero(p & r))
    fp = int(np.count_nonzero(p & ~r))
    fn = int(np.count_nonzero(~p & r))
    tn = int(np.count_nonzero(~p & ~r))
    n = tp + fp + fn + tn

    def ratio(a: float, b: float) -> float:
        return a / b if b else float("nan")

    prec, rec = ratio(tp, tp + fp), ratio(tp, tp + fn)
    f1 = ratio(2 * prec * rec, prec + rec) if tp else (0.0 if (tp + fp + fn) else float("nan"))
    p_obs = ratio(tp + tn, n)
    p_exp = ratio((tp + fp) * (tp + fn) + (fn + tn) * (fp + tn), n * n)
    kappa = ratio(p_obs - p_exp, 1.0 - p_exp) if n else float("nan")
    return {
        "tp": tp,
        "fp": fp,
        "fn": fn,
        "tn": tn,
        "precision": prec,
        "recall": rec,
        "f1": f1,
        "type_i": 100.0 * ratio(fn, tp + fn),
        "type_ii": 100.0 * ratio(fp, fp + tn),
        "total": 100.0 * ratio(fp + fn, n),
        "kappa": kappa,
    }


def reference_from_polygons(
    xy: ArrayLike,
    ref_mask: ArrayLike,
    polygons: Any,
    buffer_m: float = 1.0,
    *,
    chunk: int = 1_000_000,
) -> NDArray[np.int32]:
    """Reference object of each point from building polygons (the Delft AHN3 reference).

    A point belongs to polygon *k* when it is a reference point (``ref_mask``,
    e.g. ASPRS class 6 "building") and lies inside polygon *k* or within
    ``buffer_m`` of it; when several polygons qualify the nearest wins
    (distance 0 inside).  Overhanging roofs and facades a little outside the
    footprint are thus kept, and touching buildings are split along the
    shared edge.

    Parameters
    ----------
    xy
        ``(N, 2)`` (or ``(N, 3)``, z ignored) point coordinates in the CRS of
        the polygons.
    ref_mask
        ``(N,)`` bool, the points eligible as reference (e.g. class 6).
    polygons
        GeoDataFrame / GeoSeries / sequence of (Multi)Polygons.
    buffer_m
        Distance within which a point outside a polygon still belongs to it,
        metres (1 m by default).

    Returns
    -------
    numpy.ndarray
        ``(N,)`` int32: ``k + 1`` for the polygon in row *k*, 0 for points of
        no polygon (and for every point outside ``ref_mask``); all 0 when no
        polygon meets the points.

    Raises
    ------
    InputError
        Bad shapes, a negative buffer, empty, non-polygonal or invalid
        (self-intersecting) polygons -- the error of step 1's layer check.

    Notes
    -----
    Vectorised with a shapely 2 STRtree: a containment query (prepared
    polygons) for the points inside, then a ``dwithin`` query and exact GEOS
    point-polygon distances for the points outside; where polygons overlap,
    the lowest row wins.  Points are processed in chunks of ``chunk`` to
    bound memory.

    Examples
    --------
    >>> from shapely.geometry import box
    >>> reference_from_polygons([[0.5, 0.5], [1.6, 0.5], [5, 5]], [True, True, True],
    ...                         [box(0, 0, 1, 1), box(2, 0, 3, 1)]).tolist()
    [1, 2, 0]
    """
    pts = np.asarray(xy, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] < 2:
        raise InputError(f"xy must have shape (N, 2) or (N, 3), got {pts.shape}")
    mask = np.asarray(ref_mask)
    if mask.dtype != bool or mask.shape != (len(pts),):
        raise InputError(f"ref_mask must be a boolean array of length {len(pts)}")
    if not (np.isfinite(buffer_m) and buffer_m >= 0):
        raise InputError(f"buffer_m must be a finite distance >= 0, got {buffer_m}")
    geoms = np.asarray(getattr(polygons, "geometry", polygons), dtype=object)
    if geoms.ndim != 1:
        geoms = geoms.ravel()
    types = shapely.get_type_id(geoms)
    bad = ~np.isin(types, (3, 6)) | shapely.is_empty(geoms)  # Polygon, MultiPolygon
    if bad.any():
        raise InputError(
            "reference polygons must be non-empty (Multi)Polygons; "
            f"row {int(np.flatnonzero(bad)[0])} is not",
            hint="drop empty or non-polygon features from the layer",
        )
    invalid = ~shapely.is_valid(geoms)
    if invalid.any():  # the message of step 1 (pyheracles.io.vector.validate_polygons)
        reasons = shapely.is_valid_reason(geoms[invalid])[:3]
        raise InputError(
            f"{int(invalid.sum())} invalid polygons (rows "
            f"{np.flatnonzero(invalid)[:10].tolist()}: {'; '.join(reasons)})",
            path=getattr(polygons, "attrs", {}).get("source"),
            hint="repair them in your GIS or pass --fix-invalid (shapely.make_valid)",
        )
    labels = np.zeros(len(pts), np.int32)
    if not len(geoms):
        return labels
    tree = shapely.STRtree(geoms)
    shapely.prepare(geoms)  # speeds up the containment predicate, harmless to the caller
    cand = np.flatnonzero(mask & np.isfinite(pts[:, :2]).all(axis=1))
    for s in range(0, len(cand), chunk):  # chunks of points, each one vectorised GEOS call
        idx = cand[s : s + chunk]
        points = shapely.points(pts[idx, 0], pts[idx, 1])
        # inside (distance 0): the lowest polygon index wins where polygons overlap
        i_pt, i_poly = tree.query(points, predicate="intersects")
        if len(i_pt):  # none when the polygons miss the points (another CRS, another area)
            first = np.r_[True, i_pt[1:] != i_pt[:-1]]  # pairs are sorted by point
            labels[idx[i_pt[first]]] = i_poly[first].astype(np.int32) + 1
        if buffer_m <= 0:
            continue
        # outside every polygon but within the buffer: the nearest polygon wins
        outside = np.ones(len(idx), bool)
        outside[i_pt] = False
        rest = np.flatnonzero(outside)
        j_pt, j_poly = tree.query(points[rest], predicate="dwithin", distance=buffer_m)
        if len(j_pt):
            dist = shapely.distance(points[rest][j_pt], geoms[j_poly])
            order = np.lexsort((j_poly, dist, j_pt))
            j_pt, j_poly = j_pt[order], j_poly[order]
            first = np.r_[True, j_pt[1:] != j_pt[:-1]]
            labels[idx[rest[j_pt[first]]]] = j_poly[first].astype(np.int32) + 1
    return labels


def evaluate_by_feature(
    instance: ArrayLike,
    objects: pd.DataFrame,
    reference_instance: ArrayLike,
    reference_objects: pd.DataFrame,
    *,
    key: str = "fid",
) -> ObjectEvaluation:
    """Score step-1 objects against reference objects of the same GIS features.

    Predicted objects (``objects``: columns ``instance``, ``class``, ``key``) and
    reference objects (``reference_objects``: ``instance``, ``layer``, ``key``)
    are paired by ``layer/key``, as in the demo scene and the benchmarks.
    """
    pred = {int(i): f"{c}/{k}" for i, c, k in
            zip(objects["instance"], objects["class"], objects[key], strict=True)}  # fmt: skip
    ref = {int(i): f"{c}/{k}" for i, c, k in
           zip(reference_objects["instance"], reference_objects["layer"],
               reference_objects[key], strict=True)}  # fmt: skip
    return evaluate_objects(
        instance, reference_instance, match="key", predicted_keys=pred, reference_keys=ref,
        reference_objects=reference_objects,
    )  # fmt: skip
