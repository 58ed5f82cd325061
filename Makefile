# Every target bootstraps its own virtualenv in .venv, so a fresh clone needs only `make demo` / `make test`.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: demo reproduce akit faults rtklib smoothing calibration test lint bench clean

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip
	$(BIN)/python -m pip install -q -e '.[dev]'
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/adaptnav demo --out runs/demo --preset paper-1 --seed 1 --force

reproduce: $(STAMP)
	$(BIN)/python scripts/reproduce.py

# Issue 6: the filters on the nine Snapir AUV segments, clean and with DVL faults.
akit: $(STAMP)
	$(BIN)/python scripts/akit_eval.py

# Issue 12: every filter on paper-1/2 with simulated sensor faults -> docs/results-faults.md.
faults: $(STAMP)
	$(BIN)/python scripts/faults_eval.py

# The filters over GNSS outages on the RTKLIB car drive (real MEMS IMU + RTK).
rtklib: $(STAMP)
	$(BIN)/python scripts/rtklib_eval.py

# RTS smoothing against forward on paper-1/2 (seeds 1-10, reproduce's missions) -> docs/results-smoothing.md.
smoothing: $(STAMP)
	$(BIN)/python scripts/smoothing_eval.py

# Issue 14: DVL scale and misalignment estimated on paper-1 and A-KIT -> docs/results-calibration.md.
calibration: $(STAMP)
	$(BIN)/python scripts/calibration_eval.py

lint: $(STAMP)
	$(BIN)/ruff check src tests bench scripts
	$(BIN)/ruff format --check src tests bench scripts
	$(BIN)/mypy src

test: lint
	$(BIN)/python -m pytest -n 2 --dist loadfile

bench: $(STAMP)
	$(BIN)/python bench/run.py
	$(BIN)/python bench/sim_bench.py
	$(BIN)/python bench/csv_bench.py
	$(BIN)/python bench/stream_bench.py
	$(BIN)/python bench/sweep_bench.py
	$(BIN)/python bench/day_bench.py
	$(BIN)/python bench/cold_bench.py

clean:
	rm -rf $(VENV) runs .pytest_cache .mypy_cache .ruff_cache
