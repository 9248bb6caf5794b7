"""Files that Blender, game engines and image-animation tools open directly.

    from gesturelsm.export import export_npz, export_bvh, export_glb, export_keypoints
    export_npz(seq, "take.npz")               # BEAT2 layout (EMAGE / SMPL-X Blender add-on)
    export_bvh(seq, "take.bvh")               # SMPL-X skeleton, cm, 30 fps, Mixamo-style joint names
    export_glb(seq, "take.glb")               # skinned mesh + skeleton + animation (glTF 2.0 binary)
    export_keypoints(seq, "take_keypoints/")  # OpenPose JSON per frame, through the render camera
    export_arkit(seq, "take_face.csv")         # ARKit blendshapes + head / eye rotations, Live Link Face CSV

Units and axes everywhere: SMPL-X's (y up, the body faces +z, its left is +x); 30 fps; frame 0 = time 0.
"""
from .arkit import ARKIT_NAMES, ArkitFace, arkit_face
from .bvh import export_bvh
from .glb import export_glb, read_glb
from .keypoints import export_keypoints, keypoints_2d, keypoints_3d
from .live_link import export_arkit, read_live_link_csv
from .npz import export_npz, npz_bytes
from .skeleton import ANIMATOR_NAMES

__all__ = ["ANIMATOR_NAMES", "ARKIT_NAMES", "ArkitFace", "arkit_face", "export_arkit", "export_bvh", "export_glb",
           "export_keypoints", "export_npz", "keypoints_2d", "npz_bytes", "keypoints_3d", "read_glb",
           "read_live_link_csv"]
