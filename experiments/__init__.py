"""Dev studies and diagnoses, grouped by method: how the product's choices were measured.

Not part of the installed packages: nothing under ``common``, ``scenes``, ``sim``,
``mapping``, ``servo`` or ``scripts`` imports from here. Each study runs from the repository
root as ``python -m experiments.<area>.<name>``.
"""
