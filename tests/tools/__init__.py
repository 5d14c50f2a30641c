"""Helpers of the tests: reference writers and readers run outside the package."""
