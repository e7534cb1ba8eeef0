"""Verification against the reference library of the field (Pinocchio): per request, per
file, and across the catalogue. The only package of the library that imports Pinocchio."""
