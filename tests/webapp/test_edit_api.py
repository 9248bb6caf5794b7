"""`/edit_motion` from a Gradio API client: a client that ran `/generate_motion` edits the motion it generated in
the same session (the method choices do not wait for the page's private event that follows Generate)."""
from __future__ import annotations

import pytest

from _support import gradio_client


def _generate(client, speech_wav):
    """The motion step of the page through the API, each parameter at the default the schema reports."""
    from gradio_client import handle_file

    params = client.view_api(return_format="dict", print_info=False)["named_endpoints"]["/generate_motion"]
    args = []
    for p in params["parameters"]:
        if p["python_type"]["type"] == "filepath":
            args.append(handle_file(str(speech_wav)) if p["component"] == "Audio" else None)
        else:
            args.append(p.get("parameter_default"))
    return client.predict(*args, api_name="/generate_motion")


def test_an_api_client_edits_the_motion_it_generated(app_url, speech_wav):
    client = gradio_client(app_url)
    api = client.view_api(return_format="dict", print_info=False)["named_endpoints"]
    assert "/edit_motion" in api
    method = next(p for p in api["/edit_motion"]["parameters"] if p["component"] == "Dropdown")
    assert "gesturelsm" in method["python_type"]["type"]                  # the choices are listed to a client
    payload, table, summary, *_ = _generate(client, speech_wav)
    assert table["data"][0][0] == "GestureLSM"
    out = client.predict("gesturelsm", 0.5, 1.5, ["upper", "hands"], 3, api_name="/edit_motion")
    payload, table, summary = out[:3]
    assert payload["bodies"][0]["label"].endswith(", edited") and payload["compare"]["method"] == "gesturelsm"
    assert "**Edited:** GestureLSM: upper, hands 0.50-1.50 s, seed 3" in summary
    assert table["data"][0][0] == "GestureLSM"


def test_an_edit_before_generate_or_of_another_method_is_one_line(app_url, speech_wav):
    client = gradio_client(app_url)
    with pytest.raises(Exception, match="Generate first"):
        client.predict("gesturelsm", 0.5, 1.5, ["upper"], 3, api_name="/edit_motion")
    _generate(client, speech_wav)
    with pytest.raises(Exception, match="outside the speech|lies outside"):
        client.predict("gesturelsm", 0.5, 1e308, ["upper"], 3, api_name="/edit_motion")
