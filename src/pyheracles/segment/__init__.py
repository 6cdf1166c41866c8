"""Segmentation building blocks: Euclidean clustering and region growing."""
