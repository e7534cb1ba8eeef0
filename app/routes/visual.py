"""The robot as it looks: ``GET /models/{id}/visual`` and ``GET /models/{id}/visual/meshes/{index}``.

The listing gives each link's URDF ``<visual>`` elements (primitives with their sizes, meshes with
their scale and, when the model may serve it, the URL of the mesh's bytes); the bytes route serves
them read-only. Which meshes are served is the library's decision
(:func:`kinematics.usecases.visual_mesh`): catalogue models' from the installed packages,
uploaded archives' from the archive's own members the registry keeps, a plain upload's none. This
module opens no file.
"""

from __future__ import annotations

from urllib.parse import quote

from fastapi import APIRouter, Depends, Request
from fastapi.responses import Response
from pydantic import BaseModel, Field

from kinematics import usecases
from kinematics.usecases.visual import MESH_MEDIA_TYPES

from ..adapter import error_responses
from ..deps import ModelId, RegistryDep, require_read_key

router = APIRouter(tags=["visual"], dependencies=[Depends(require_read_key)])

#: meshes are re-validated on every load (a model id may be re-registered)
MESH_CACHE_CONTROL = "no-cache"


class VisualElementOut(BaseModel):
    """One ``<visual>`` element of a link."""

    kind: str = Field(description="box | cylinder | sphere | mesh")
    origin: list[list[float]] = Field(description="T_link_visual, 4x4 row-major")
    size: list[float] = Field(description="box: [x, y, z]; cylinder: [radius, length]; sphere: [radius]; mesh: []")
    scale: list[float] = Field(description="mesh: [sx, sy, sz]")
    color: list[float] | None = Field(description="the URDF material's rgba in [0, 1], or null")
    source: str | None = Field(None, description="mesh: the file name the URDF wrote")
    format: str | None = Field(None, description="mesh: stl | obj | dae (when served)")
    url: str | None = Field(None, description="mesh: where its bytes are served; null when the model serves it not")


class VisualOut(BaseModel):
    model: str
    links: dict[str, list[VisualElementOut]] = Field(description="per link (every link), its visuals in URDF order")
    meshes: int = Field(description="the number of meshes served")
    warnings: list[str] = Field(description="what is not drawn, and why")


@router.get("/models/{model_id}/visual", response_model=VisualOut, summary="The visual elements of a model's links",
            responses=error_responses({404: "unknown model"}, statuses=(404,)))
def visual(model_id: ModelId, request: Request, registry: RegistryDep) -> VisualOut:
    """Per link its URDF `<visual>` elements with `origin` = `T_link_visual`: boxes, cylinders and
    spheres with their size; meshes with their `scale` and a `url` for their bytes -- for
    catalogue models (the installed packages) and uploaded archives (the archive's own members);
    a plain upload's meshes are never read (`url` null, `warnings` say so)."""
    rec = registry.get(model_id)
    g = usecases.visual_geometry(rec.model)
    root = request.scope.get("root_path", "").rstrip("/")
    base = f"{root}/models/{quote(rec.id, safe='')}/visual/meshes/"
    return VisualOut(
        model=rec.id, meshes=g.meshes, warnings=list(g.warnings),
        links={link: [VisualElementOut(kind=v.kind, origin=v.origin.tolist(), size=list(v.size),
                                       scale=list(v.scale), color=None if v.color is None else list(v.color),
                                       source=v.source, format=v.format,
                                       url=None if v.mesh is None else f"{base}{v.mesh}")
                      for v in elements] for link, elements in g.visuals.items()},
    )


@router.get("/models/{model_id}/visual/meshes/{index}", summary="The bytes of one visual mesh",
            response_class=Response,
            responses={200: {"content": {t: {} for t in MESH_MEDIA_TYPES.values()},
                             "description": "the mesh file (STL, OBJ or Collada)"},
                       **error_responses({404: "unknown model, or a mesh the model does not serve"}, statuses=(404,))})
def visual_mesh(model_id: ModelId, index: str, registry: RegistryDep) -> Response:
    """The bytes of visual mesh `index` (the `url` of `GET /models/{id}/visual`), read-only:
    404 for anything but an index the model serves."""
    data, _, media_type = usecases.visual_mesh(registry.get(model_id).model, index)
    return Response(data, media_type=media_type, headers={"Cache-Control": MESH_CACHE_CONTROL})
