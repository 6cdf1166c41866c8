"""Geometry shared by every step: neighbourhoods, fitting, sections."""
