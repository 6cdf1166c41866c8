"""Registration and georeferencing of point clouds (quality control of integration).

Similarity (Helmert) transforms with robust estimators, point lists, check point
validation, ICP, automatic tie points through window panes, target measurement and
the integration strategies of the thesis (Murtiyoso 2020, ch. 3).  Submodules load
lazily only what they use (matplotlib only for the residual map).
"""

from pyheracles.registration.checkpoints import (
    CheckPointReport,
    ResidualPropagation,
    check_points,
    plot_residual_map,
    propagate_residuals,
)
from pyheracles.registration.icp import ICPParams, ICPResult, icp
from pyheracles.registration.points import (
    PointList,
    pair_points,
    read_point_groups,
    read_points,
    write_points,
)
from pyheracles.registration.similarity import (
    ESTIMATORS,
    SimilarityParams,
    SimilarityResult,
    estimate_similarity,
    similarity_matrix,
)
from pyheracles.registration.strategies import (
    BlockParams,
    BlockResult,
    CloudMeasurements,
    FreeNetworkResult,
    block_adjustment,
    free_network,
    georeference_independent,
)
from pyheracles.registration.targets import (
    fit_sphere,
    measure_plane_corner,
    measure_sphere,
    measure_spheres,
)
from pyheracles.registration.tiepoints import TiePointParams, TiePointResult, find_tie_points
from pyheracles.registration.transform import (
    apply_to_cloud,
    apply_to_points,
    read_transform_json,
    write_transform_json,
)

__all__ = [
    "ESTIMATORS",
    "BlockParams",
    "BlockResult",
    "CheckPointReport",
    "CloudMeasurements",
    "FreeNetworkResult",
    "ICPParams",
    "ICPResult",
    "PointList",
    "ResidualPropagation",
    "SimilarityParams",
    "SimilarityResult",
    "TiePointParams",
    "TiePointResult",
    "apply_to_cloud",
    "apply_to_points",
    "block_adjustment",
    "check_points",
    "estimate_similarity",
    "find_tie_points",
    "fit_sphere",
    "free_network",
    "georeference_independent",
    "icp",
    "measure_plane_corner",
    "measure_sphere",
    "measure_spheres",
    "pair_points",
    "plot_residual_map",
    "propagate_residuals",
    "read_point_groups",
    "read_points",
    "read_transform_json",
    "similarity_matrix",
    "write_points",
    "write_transform_json",
]
