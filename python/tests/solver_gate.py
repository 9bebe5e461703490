"""`require(module)`: import a solver package for the solver tests, or skip saying why;
under CI (`CI=true`) a missing package fails the test instead of skipping it."""

import importlib
import os

import pytest


def in_ci() -> bool:
    return os.environ.get("CI", "").lower() in ("1", "true", "yes")


def require(module: str, install: str):
    """The imported `module`; when it cannot be imported, a skip naming the reason and
    how to install it (`install`), or under CI a failure."""
    try:
        return importlib.import_module(module)
    except Exception as exc:  # ImportError, or a shared library missing
        reason = f"{module} cannot be imported ({type(exc).__name__}: {exc}); {install}"
        if in_ci():
            pytest.fail(f"CI must run the solver tests: {reason}", pytrace=False)
        pytest.skip(reason)
