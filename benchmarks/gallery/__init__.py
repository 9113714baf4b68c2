"""The figures of the gallery examples that the documentation build does not run, from a full run of each."""
