"""Liveness."""

from __future__ import annotations

from fastapi import APIRouter

import kinematics
from kinematics.crosscheck import PINOCCHIO_VERSION

from ..deps import RegistryDep
from ..schemas import Health

router = APIRouter(tags=["health"])


@router.get("/health", response_model=Health)
def health(registry: RegistryDep) -> Health:
    """Liveness: status, service version, Pinocchio version and the number of bundled models."""
    return Health(version=kinematics.__version__, pinocchio_version=PINOCCHIO_VERSION,
                  bundled_models=len(registry.catalogue.ids()))
