"""Figures of one notebook each that are not its lesson (one module per notebook topic, as ``exercises``):
the notebook calls one function and keeps its computations and checks in view."""
