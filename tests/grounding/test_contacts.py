"""Contacts from height and speed (grounding/contacts.py): the causal machine and the whole-take form agree, the
hysteresis holds a state between its thresholds, and the offline form moves contacts back to the real landing."""
from __future__ import annotations

import numpy as np

from gesturelsm.grounding.contacts import (ContactDetector, ContactParams, causal_contacts, detect_contacts,
                                           segments)


def test_the_vectorised_machine_is_the_frame_by_frame_detector():
    rng = np.random.default_rng(0)
    h = np.abs(rng.normal(0.04, 0.03, (400, 2)))
    v = np.abs(rng.normal(0.4, 0.3, (400, 2)))
    h[::37] = np.nan                                          # a broken frame lifts, never crashes
    det = ContactDetector(2)
    frame_by_frame = np.array([det.step(h[t], v[t]) for t in range(len(h))])
    np.testing.assert_array_equal(causal_contacts(h, v), frame_by_frame)
    assert frame_by_frame.any() and not frame_by_frame.all()


def test_hysteresis_holds_the_state_between_the_thresholds():
    p = ContactParams()
    T = 300
    h = np.full((T, 1), 0.01)
    h[100:] = np.random.default_rng(1).uniform(p.height_on + 0.001, p.height_off - 0.001, (T - 100, 1))
    v = np.zeros((T, 1))
    c = causal_contacts(h, v, p)
    assert c[p.frames_on:].all()                             # landed, then hovering between thresholds: still down
    h[:100] = 0.2                                            # starting up in the air ...
    assert not causal_contacts(h, v, p).any()                # ... the same hovering never lands
    single = h.copy()
    single[:] = 0.2
    single[150] = 0.0                                        # one low frame is not a landing
    assert not causal_contacts(single, v, p).any()


def test_offline_contacts_start_when_the_foot_landed_and_end_when_it_lifted():
    p = ContactParams()
    T = 120
    h = np.full((T, 1), 0.2)
    h[40:90] = 0.0
    v = np.zeros((T, 1))
    assert segments(causal_contacts(h, v, p)[:, 0]) == [(40 + p.frames_on - 1, 90 + p.frames_off - 1)]
    assert segments(detect_contacts(h, v, p)[:, 0]) == [(40, 90)]
    h[90:100] = np.linspace(0.01, 0.1, 10)[:, None]          # rising slowly (1 cm a frame): it lifted after the
    assert segments(detect_contacts(h, v, p)[:, 0]) == [(40, 92)]   # last frame below height_on (91, 2 cm up)


def test_offline_contacts_close_short_lifts_and_drop_short_touches():
    p = ContactParams()
    T = 200
    h = np.full((T, 1), 0.2)
    h[20:60] = h[60 + p.min_gap - 1:120] = 0.0               # a lift shorter than min_gap
    h[150:150 + p.min_contact - 1] = 0.0                     # a touch shorter than min_contact
    v = np.zeros((T, 1))
    assert segments(detect_contacts(h, v, p)[:, 0]) == [(20, 120)]


def test_a_fast_foot_is_not_in_contact_however_low():
    T = 100
    assert not detect_contacts(np.zeros((T, 1)), np.full((T, 1), 2.0)).any()
