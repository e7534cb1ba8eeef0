"""Wire schemas of workspace sampling (``POST /models/{id}/workspace``)."""

from __future__ import annotations

from typing import Literal, Union

from pydantic import BaseModel, ConfigDict, Field

from .common import ToQuery, _POINT_DESC, _TOOL_DESC, BasePose, Flag, Integer, Finite, Number, Point, Vector

class WorkspaceRequest(ToQuery, BaseModel):
    model_config = ConfigDict(extra="forbid")
    link: str | None = Field(default=None, description="the link (default: the first leaf link)")
    point: Union[Point, None] = Field(default=None, description=_POINT_DESC)
    tool: Union[BasePose, None] = Field(default=None, description=_TOOL_DESC)
    samples: Integer = Field(default=100_000, ge=1, description="configurations drawn uniformly within the joint limits "
                                                             "(bounded by the max_workspace_samples setting)")
    random_seed: Integer = Field(default=0, ge=0, le=2**63 - 1, description="seed of the draws: same inputs, same answer")
    voxel: Finite | None = Field(default=None, gt=0, description="edge of the occupancy-grid cells, metres (default: "
                                                                "chosen so that the bounding box has about samples/16 cells)")
    measure: Literal["pose", "position"] = Field(
        default="pose", description="manipulability: product of the singular values of the 6 x k local_world_aligned "
                                    "Jacobian over the k joints on the path (pose) or of its 3 position rows (position)")
    collision_free: Flag = Field(
        default=False, description="keep only the samples free of self-collision (joints off the link's path at the "
                                   "middle of their limits); dropped counts the others. A model without collision "
                                   "geometry: 422")


class BoundingBox(BaseModel):
    min: Vector
    max: Vector


class ConvergenceStep(BaseModel):
    samples: int
    volume: float | None = Field(default=None, description="m³ (spatial workspaces)")
    area: float | None = Field(default=None, description="m² (planar workspaces)")


class ManipulabilityStats(BaseModel):
    min: float
    mean: float
    max: float


class WorkspaceResponse(BaseModel):
    model: str
    link: str
    samples: int = Field(description="samples analysed (with collision_free: those kept)")
    collision_free: bool = Field(default=False, description="only samples free of self-collision were kept")
    dropped: int = Field(default=0, description="with collision_free: samples drawn and left out as in self-collision")
    random_seed: int
    measure: Literal["pose", "position"]
    dimension: int = Field(description="3: the samples fill space; 2: they lie in a plane (a planar arm); 1, 0")
    bounding_box: BoundingBox
    reach: float = Field(description="largest distance of a sample from the root frame's origin, metres")
    volume: float = Field(description="occupancy-grid estimate, m³ (0 for a planar workspace)")
    area: float | None = Field(default=None, description="planar workspaces: the area, m²")
    convergence: list[ConvergenceStep] = Field(description="the estimate over the first N/4, N/2 and N samples")
    converged: bool = Field(description="the samples are dense for the voxel and the estimate settled from N/2 to N")
    advice: str | None = Field(default=None, description="when not converged: why, and what to change (a larger "
                                                         "voxel, more samples)")
    voxel: float = Field(description="the cell edge asked for or chosen, metres")
    cell: Vector = Field(description="the grid's cell edges along its axes (each <= voxel, so whole cells tile the "
                                     "bounding box; 0 along a flat axis)")
    occupied_voxels: int = Field(description="cells holding a sample (the dexterity map's size; its cells and best "
                                             "manipulability come with Accept: application/x-npz)")
    manipulability: ManipulabilityStats


WORKSPACE_EXAMPLES = {
    "ur5_converged": {"summary": "UR5 tool0, 200,000 samples in 15 cm cells: converged",
                      "value": {"link": "tool0", "samples": 200000, "voxel": 0.15}},
    "ur5": {"summary": "UR5 tool0, 100,000 samples (not converged: the advice says why)",
            "value": {"link": "tool0", "samples": 100000}},
    "ur5_tcp": {"summary": "a TCP 10 cm along tool0's z, position manipulability, 5 cm cells",
                "value": {"link": "tool0", "point": [0, 0, 0.1], "samples": 200000, "voxel": 0.05,
                          "measure": "position", "random_seed": 7}},
    "ur5_free": {"summary": "UR5 tool0, the 20,000 samples' collision-free part",
                 "value": {"link": "tool0", "samples": 20000, "collision_free": True}},
}

