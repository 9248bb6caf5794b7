"""The page's Edit on Ray Serve replicas (`python -m app --replicas N`): the edit is made by a replica, through Serve's
handle, with the motion this process makes for the same edit; its folder is inside the request's on the front end."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import soundfile as sf

from gesturelsm.cluster import parse_cluster, parse_replicas

from _support import speech_like


def test_an_edit_on_a_replica_is_the_edit_made_here(ray_cluster, tiny_assets, tmp_path, monkeypatch):
    from gesturelsm.serve.config import ServiceSettings
    from gesturelsm.serve.editing import root_folder
    from gesturelsm.serve.replicated import ReplicatedService
    from gesturelsm.serve.request import Request
    from gesturelsm.serve.service import GestureService

    settings = ServiceSettings(checkpoints=str(tiny_assets), workdir=str(tmp_path / "front"), max_seconds=20)
    service = ReplicatedService.start(settings, parse_replicas("1"), parse_cluster("auto"), warmup=False,
                                      name="gesturelsm-edit")
    try:
        wav = tmp_path / "speech.wav"
        sf.write(wav, speech_like(4.0, seed=2), 16000)
        first = service.run(Request(str(wav), methods=("gesturelsm",), steps={"gesturelsm": 2}, render=False,
                                    exports=False, transcribe=False))
        made_here = []
        monkeypatch.setattr(service.local, "edit", lambda *a, **k: made_here.append(a))
        edited = service.edit(first, "gesturelsm", 1.0, 2.5, ["upper", "hands"], 9)
        assert made_here == [] and edited.previous is first and root_folder(edited) == first.job.folder
        assert Path(edited.job.folder).is_dir() and edited.job.folder.parent == first.job.folder
    finally:
        service.close()
    here = GestureService.from_settings(ServiceSettings(checkpoints=str(tiny_assets), workdir=str(tmp_path / "here"),
                                                        max_seconds=20))
    same = here.edit(first, "gesturelsm", 1.0, 2.5, ["upper", "hands"], 9)
    np.testing.assert_array_equal(edited.motions["gesturelsm"].poses, same.motions["gesturelsm"].poses)
