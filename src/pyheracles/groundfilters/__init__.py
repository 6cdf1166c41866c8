"""Ground filter implementations behind :mod:`pyheracles.ground` (the public face).

- :mod:`.surface`: the ground surface as a raster (:class:`DTM`), rasterising and inpainting.
- :mod:`.smrf`: the Simple Morphological Filter (Pingel et al. 2013).
- :mod:`.csf`: the Cloth Simulation Filter (Zhang et al. 2016) through ``cloth-simulation-filter``.
- :mod:`.auto`: parameters measured from the cloud (point spacing, terrain slope).
"""
