"""The Gradio API as `view_api()` describes it: a client that sends exactly the types the schema reports (choices
as the strings it lists, sliders as floats) gets results, and every output carries a name a caller can read."""
from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

from _support import gradio_client


def _api(url) -> dict:
    return gradio_client(url).view_api(return_format="dict", print_info=False)["named_endpoints"]


def _literals(python_type: str) -> list:
    """The choices of a `Literal[...]` (or `list[Literal[...]]`) type string, as the schema writes them."""
    inner = re.search(r"Literal\[(.*?)\]", python_type).group(1)
    return list(ast.literal_eval(f"[{inner}]"))


def _typed(param: dict, speech):
    """A value of exactly the type the schema reports for `param` (its default where it has one)."""
    from gradio_client import handle_file

    kind, default = param["python_type"]["type"], param.get("parameter_default")
    if kind == "filepath":
        return handle_file(str(speech)) if param["component"] == "Audio" else None
    if kind.startswith("list[Literal["):
        return _literals(kind)[:1]
    if kind.startswith("Literal["):
        choices = _literals(kind)
        return str(default) if str(default) in choices else choices[0]
    return {"str": lambda d: "hello there", "float": float, "int": int, "bool": bool}[kind](default)


def test_outputs_have_readable_names(app_url):
    unnamed = [(name, ret.get("label")) for name, ep in _api(app_url).items() for ret in ep["returns"]
               if not ret.get("label") or re.fullmatch(r"value_\d+", ret["label"])]
    assert unnamed == []


def test_generate_accepts_the_types_view_api_reports(app_url, speech_wav):
    params = _api(app_url)["/generate"]["parameters"]
    size = next(p for p in params if p["parameter_name"] == "size")
    assert size["python_type"]["type"].startswith("Literal['")           # choices listed as strings
    args = [_typed(p, speech_wav) for p in params]
    assert args[[p["parameter_name"] for p in params].index("size")] == str(size["parameter_default"])
    video, table, summary, files, glb = gradio_client(app_url).predict(*args, api_name="/generate")
    assert Path(video).stat().st_size > 1000 and Path(glb).suffix == ".glb"
    assert len(table["data"]) == 2 and summary                          # the method, then the total row


@pytest.mark.parametrize("field", ["size", "smoothing"])
def test_every_listed_choice_is_accepted(app_url, speech_wav, field):
    """Each choice the schema lists, sent as the schema writes it, passes the field checks (the motion step;
    no video is rendered)."""
    params = _api(app_url)["/generate_motion"]["parameters"]
    names = [p["parameter_name"] for p in params]
    base = [_typed(p, speech_wav) for p in params]
    choices = _literals(params[names.index(field)]["python_type"]["type"])
    assert len(choices) >= 4
    client = gradio_client(app_url)
    for choice in choices:
        args = list(base)
        args[names.index(field)] = choice
        payload, table, summary, text, status = client.predict(*args, api_name="/generate_motion")
        assert len(table["data"]) == 2, (field, choice, summary)


def test_a_size_outside_the_list_is_refused_with_the_fields_message(app_url, speech_wav):
    params = _api(app_url)["/generate_motion"]["parameters"]
    names = [p["parameter_name"] for p in params]
    args = [_typed(p, speech_wav) for p in params]
    args[names.index("size")] = "300"
    with pytest.raises(Exception, match="Video size"):
        gradio_client(app_url).predict(*args, api_name="/generate_motion")
