# make test  - create .venv, install everything, run the test suite
# make test-fast - the same without slow and browser tests (the edit-test loop)
#   both run TEST_WORKERS test processes (pytest-xdist; one math thread each, see tests/conftest.py)
# make demo  - create .venv, install everything, start the web app on http://127.0.0.1:7860
#   REPLICAS=N (or MIN:MAX): generation and rendering in N Ray Serve replicas on this machine (docs/CLUSTER.md)
VENV ?= .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.setup-done
export NUMBA_CACHE_DIR ?= $(CURDIR)/$(VENV)/numba-cache
export GRADIO_ANALYTICS_ENABLED := False
export HF_HUB_DISABLE_TELEMETRY := 1
TEST_WORKERS ?= 2
PYTEST := $(PY) -m pytest -q -n $(TEST_WORKERS) --dist loadgroup

.PHONY: setup test test-fast demo clean
setup: $(STAMP)

PLAYER := gesturelsm/webapp/player
$(STAMP): requirements.txt pyproject.toml setup.py scripts/setup.sh $(PLAYER)/package-lock.json \
          $(PLAYER)/package.json $(wildcard $(PLAYER)/src/*)
	VENV=$(VENV) bash scripts/setup.sh
	touch $@

test: $(STAMP)
	$(PYTEST)

test-fast: $(STAMP)
	$(PYTEST) -m "not slow and not browser"

demo: $(STAMP)
	$(PY) -m app $(if $(REPLICAS),--replicas $(REPLICAS))

clean:
	rm -rf $(VENV) .pytest_cache
