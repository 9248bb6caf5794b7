"""The methods' facts are declared without torch (flows/facts.py) and are the ones their classes carry, in the
registry's order."""
from __future__ import annotations

from gesturelsm import flows
from gesturelsm.flows.facts import FACTS


def test_each_class_carries_its_declared_facts_in_registry_order():
    assert list(flows.METHODS) == list(FACTS)
    assert all(cls.facts is FACTS[key] for key, cls in flows.METHODS.items())
    assert flows.method_facts("ddim").max_steps == flows.DDIM.facts.max_steps == 1000

