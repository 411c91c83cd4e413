# IceImpact: two commands for a fresh machine.
#   make demo   set up .venv, build dist/IceImpact.fmu, simulate the reference scene through FMPy
#   make test   set up .venv and run the test suite
#   make docs   the documentation site into site/ (mkdocs build --strict)
#   make look   the site and the page inside IceImpact.fmu looked at in headless Chromium at
#               1280 px: screenshots into out/look/shots/, exit status 1 on a table, code block
#               or picture cut off or a variable name broken (installs Debian's chromium and
#               playwright into .venv when missing; not part of make test)
#   make verify the article's headline figures checked in seconds (exit status 3 on a difference)
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed

.PHONY: setup demo test test-all fmu standalone bench verify reproduce regime-map docs look lint \
	clean

setup: $(STAMP)

$(STAMP): pyproject.toml
	@bash scripts/system-deps.sh
	@test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[dev]'
	@touch $(STAMP)

fmu: $(STAMP)
	$(PY) build_fmu.py

# the FMUs with their own Python, numpy and scipy, for machines without Python (dist/standalone/)
standalone: $(STAMP)
	$(PY) build_fmu.py --standalone

demo: $(STAMP)
	$(PY) build_fmu.py
	$(PY) examples/demo.py

test: $(STAMP)
	$(PY) -m pytest -q -m "not slow"

test-all: $(STAMP)
	$(PY) -m pytest -q

bench: $(STAMP)
	$(PY) benchmarks/core_speed.py

# the headline figures in seconds: Figure 2 and Figure 13 (the lock-in) against the numbers the
# docs quote, and Figure 2 through the FMU (exit status 3 on a difference); writes only dist/
verify: $(STAMP)
	$(PY) build_fmu.py
	$(PY) examples/verify_headlines.py

# the article's figures and its lock-in case through the FMU, each number
# docs/explanation/reproduction.md quotes checked against the runs (exit status 3 on a
# difference); rewrites docs/img/fig*.png. regime-map: the regime map (~15 s)
reproduce: $(STAMP)
	$(PY) build_fmu.py
	$(PY) examples/reproduce_linear.py --img-dir docs/img --check-doc docs/explanation/reproduction.md
	$(PY) examples/reproduce_quadratic.py --img-dir docs/img --check-doc docs/explanation/reproduction.md
	$(PY) examples/lockin.py

regime-map: $(STAMP)
	$(PY) examples/regime_map.py

# the documentation site into site/ (any broken link, anchor or reference fails the build)
docs: $(STAMP)
	$(VENV)/bin/mkdocs build --strict --site-dir site

# the pages a reader opens first, in a real browser (scripts/look_at_docs.py says what it measures);
# Chromium is Debian's, Playwright only drives it: neither is a dependency of the package
look: $(STAMP)
	@command -v chromium >/dev/null || { SUDO=$$([ "$$(id -u)" -eq 0 ] || echo sudo); \
	  $$SUDO apt-get update -qq && \
	  DEBIAN_FRONTEND=noninteractive $$SUDO apt-get install -y -qq chromium >/dev/null; }
	@$(PY) -c "import playwright" 2>/dev/null || $(PY) -m pip install --quiet playwright
	$(VENV)/bin/mkdocs build --strict --quiet --site-dir out/look/site
	$(PY) build_fmu.py --fmu IceImpact --dest out/look
	$(PY) scripts/look_at_docs.py out/look/site out/look/IceImpact.fmu --shots out/look/shots

lint: $(STAMP)
	$(PY) -m ruff check fmu_src tests tools benchmarks examples scripts build_fmu.py fmu_build

clean:
	rm -rf dist out build site .pytest_cache
