"""Exports of results to other tools' formats: CityJSON for 3D GIS (:mod:`.cityjson`),
IFC for BIM (:mod:`.ifc`); solids are checked with :mod:`.validate_solid`.

Submodules are imported on use (no heavy import at package import time).
"""
