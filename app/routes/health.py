"""Liveness."""

from __future__ import annotations

from fastapi import APIRouter

import kinematics
from kinematics.usecases import reference_name

from ..deps import RegistryDep
from ..schemas import Health
from ..warm import process_warm_up

router = APIRouter(tags=["health"])

#: the reference library's version (read at import, so no request pays for importing it)
REFERENCE_VERSION = reference_name().removeprefix("pinocchio ")


@router.get("/health", response_model=Health)
async def health(registry: RegistryDep) -> Health:
    """Liveness: status, service version, Pinocchio version, the number of bundled models and whether
    the compiled kernels are loaded yet (``warm_up``)."""
    return Health(version=kinematics.__version__, pinocchio_version=REFERENCE_VERSION,
                  bundled_models=len(registry.catalogue.ids()), warm_up=process_warm_up().state)
