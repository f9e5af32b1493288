"""A reconstruction's points as files other tools open: PLY (streamed) and GLB.

PLY is written here, chunk by chunk (`Reconstruction.ply_chunks`), so a large cloud streams out
without being built in memory first. GLB (binary glTF) is trimesh's writer: a POINTS primitive with
RGBA vertex colours. Both keep the reconstruction's world frame as it is (no axis change: OpenCV
axes for the reference camera; glTF viewers that assume y up may show it upside down).
"""

from __future__ import annotations

import numpy as np

from shared.geometry.reconstruction import Reconstruction

PLY_MEDIA_TYPE = "application/x-ply"
GLB_MEDIA_TYPE = "model/gltf-binary"


def to_glb(recon: Reconstruction) -> bytes:
    import trimesh  # only for this download: it is not needed to reconstruct

    opaque = np.full((recon.num_points, 1), 255, dtype=np.uint8)
    cloud = trimesh.PointCloud(recon.points, colors=np.concatenate([recon.colors, opaque], axis=1))
    return cloud.export(file_type="glb")


__all__ = ["GLB_MEDIA_TYPE", "PLY_MEDIA_TYPE", "to_glb"]
