"""What makes a request's motion in this process, handed to the request flows (`serve/progressive.py`,
`serve/sweep.py`) as one typed value: the pipeline and the body, the checks and the speech preparation (`Intake`),
the runs made ahead (`Ahead`), the request folders (`RequestFolders`) and the math threads."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ..pipeline import GesturePipeline
from .ahead import Ahead
from .intake import Intake
from ..request_files import RequestFolders


@dataclass(frozen=True)
class Workshop:
    pipeline: GesturePipeline
    body: Any                                 # the body model (a `body.BodyModel`; None: the default's file)
    intake: Intake                            # the upload's checks and its speech, prepared once
    ahead: Ahead                              # the server's one run made ahead; requests count as generating
    folders: RequestFolders                   # a request's folder: new, and the old ones deleted
    threads: int                              # math threads of the thread that generates


__all__ = ["Workshop"]
