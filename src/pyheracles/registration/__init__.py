"""Registration and georeferencing of point clouds (quality control of integration).

Similarity (Helmert) transforms with robust estimators, point lists, check point
validation, ICP, automatic tie points through window panes, target measurement and
the integration strategies of the thesis (Murtiyoso 2020, ch. 3).
"""

from pyheracles.registration.similarity import (
    ESTIMATORS,
    SimilarityParams,
    SimilarityResult,
    estimate_similarity,
    similarity_matrix,
)

__all__ = [
    "ESTIMATORS",
    "SimilarityParams",
    "SimilarityResult",
    "estimate_similarity",
    "similarity_matrix",
]
