"""Residual diagnosis: explain what the neural part of a hybrid model learned with named terms."""

from .library import CandidateLibrary
from .sparse import SparseTermRegression

__all__ = ["CandidateLibrary", "SparseTermRegression"]
