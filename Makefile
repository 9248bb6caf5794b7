# make test  - create .venv, install everything, run the test suite
# make demo  - create .venv, install everything, start the web app on http://127.0.0.1:7860
VENV ?= .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.setup-done
export NUMBA_CACHE_DIR ?= $(CURDIR)/$(VENV)/numba-cache
export GRADIO_ANALYTICS_ENABLED := False
export HF_HUB_DISABLE_TELEMETRY := 1

.PHONY: setup test demo clean
setup: $(STAMP)

$(STAMP): requirements.txt pyproject.toml setup.py scripts/setup.sh app/player/package-lock.json \
          app/player/package.json $(wildcard app/player/src/*)
	VENV=$(VENV) bash scripts/setup.sh
	touch $@

test: $(STAMP)
	$(PY) -m pytest -q

demo: $(STAMP)
	$(PY) -m app

clean:
	rm -rf $(VENV) .pytest_cache
