"""Liveness."""

from __future__ import annotations

from fastapi import APIRouter

import kinematics
from kinematics.api import reference_name

from ..deps import RegistryDep
from ..schemas import Health

router = APIRouter(tags=["health"])


@router.get("/health", response_model=Health)
def health(registry: RegistryDep) -> Health:
    """Liveness: status, service version, Pinocchio version and the number of bundled models."""
    return Health(version=kinematics.__version__, pinocchio_version=reference_name().removeprefix("pinocchio "),
                  bundled_models=len(registry.catalogue.ids()))
