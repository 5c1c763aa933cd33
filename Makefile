# cpgjax: `make run` (short evolution of the quadruped) and `make test` (the suite).
PY ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: run test test-all test-slow lint bench thesis setup clean readme

$(STAMP): pyproject.toml
	$(PY) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip
	$(BIN)/python -m pip install -q -e ".[dev,cluster]"
	touch $(STAMP)

setup: $(STAMP)

# make run: a short evolution that ends with a gait that walks, here and in MuJoCo C.  The hand-written trot of
# models/quadruped-trot.ctl is the start, the exact pipeline the physics, and every controller is scored over 4
# episodes of domain randomisation (rough ground 0-4 cm, friction, masses, servo gains, the ground's stiffness:
# docs/robust-evaluation.md); `cpgjax transfer` then replays the best in both engines, 32 jittered times each.
# Its last line is make run's last line: whether the gait stays up and carries over (the hints come before it;
# tests/test_readme.py checks the order).  The thesis's single-episode GA is `make thesis`.
QUICK := runs/quickstart
run: $(STAMP)
	$(BIN)/cpgjax evolve models/quadruped.wl --start models/quadruped-trot.ctl --pipeline exact \
		--evaluation robust --perturb preset=domain --population 20 --generations 15 --time 5 --pocket 4 \
		--gamma 0.01 --chunk 5 --seed 0 --out $(QUICK).h5 --overwrite
	$(BIN)/cpgjax plot $(QUICK).h5 --out $(QUICK).png
	$(BIN)/cpgjax best $(QUICK).h5 --ctl $(QUICK)-best.ctl
	@echo ""
	@echo "fitness plot: $(QUICK).png   best controller: $(QUICK)-best.ctl"
	@echo "replay it:  $(BIN)/cpgjax simulate models/quadruped.wl --ctl $(QUICK)-best.ctl"
	@echo "watch it, here and in MuJoCo side by side:  MUJOCO_GL=egl $(BIN)/cpgjax render $(QUICK).h5 --engine both --out $(QUICK).mp4"
	@echo "cpgjax is installed in $(VENV), not on your PATH: run it as $(BIN)/cpgjax COMMAND,"
	@echo "or first 'source $(BIN)/activate' and then just cpgjax COMMAND (cpgjax --help lists them)"
	@echo ""
	@echo "the best gait replayed in our simulator and in MuJoCo C (into $(QUICK)-transfer/); the last line says whether it carries over:"
	$(BIN)/cpgjax transfer $(QUICK).h5 --out $(QUICK)-transfer

lint: $(STAMP)
	$(BIN)/ruff check cpgjax tests benchmarks

# the fast suite; it ends with its ten slowest tests, its time (wall and CPU) and the load it ran under.
# pytest's "no tests ran" (exit 5) fails like any other failure.  TEST_WORKERS pytest-xdist workers (one per core
# of the 2-core machine the suite is sized for; 0: one process), each running whole files, the heaviest first
# (tests/conftest.py): XLA compiles a program on one core, so one process left the second core mostly idle.
TEST_WORKERS ?= 2
PYTEST := $(BIN)/python -m pytest -q --durations=10 -n $(TEST_WORKERS) --dist loadfile --no-loadscope-reorder
test: $(STAMP) lint
	$(PYTEST) -m "not slow"

# every test, the long checks marked slow included (docs/architecture.md, "Tests", lists them)
test-all: $(STAMP) lint
	$(PYTEST)

# only the tests marked slow (CI runs them after `make test`)
test-slow: $(STAMP)
	$(PYTEST) -m slow

# rewrite the README's command examples from a fresh run (tests/test_readme.py checks them)
readme: $(STAMP)
	UPDATE_README=1 $(BIN)/python -m pytest -q tests/test_readme.py

bench: $(STAMP)
	$(BIN)/cpgjax bench

# the thesis's evolution experiment (Fig. 6.5-6.12), 5 seeds, about 40 minutes on 2 cores; resumable
thesis: $(STAMP)
	$(BIN)/cpgjax sweep models/quadruped.wl --preset full --out runs/thesis
	$(BIN)/cpgjax notebook notebooks/thesis_figures.ipynb --scale full --out runs/thesis/thesis_figures.ipynb
	$(BIN)/cpgjax report runs/thesis > /dev/null
	@echo "figures: docs/figures/fig-6-*.png   claims table: runs/thesis/report.md"

clean:
	rm -rf $(VENV) build *.egg-info

# redraw the README's GIFs with today's code (tests/test_figures.py checks each GIF's line in README.md)
.PHONY: figures
figures: $(STAMP)
	export MUJOCO_GL=$${MUJOCO_GL:-egl}; \
	$(BIN)/cpgjax render models/quadruped.wl --ctl models/quadruped-trot.ctl --time 6 --camera fixed --fps 15 --size 320x240 --out docs/figures/render-trot.gif && \
	$(BIN)/cpgjax render models/quadruped.wl --ctl models/quadruped-robust.ctl --time 6 --camera fixed --fps 15 --size 320x240 --out docs/figures/render-evolved.gif && \
	$(BIN)/cpgjax render models/hexapod.wl --ctl models/hexapod.ctl --time 6 --camera fixed --fps 15 --size 320x240 --out docs/figures/render-hexapod.gif && \
	$(BIN)/cpgjax render models/worm.wl --ctl models/worm.ctl --time 6 --camera side --fps 10 --size 320x240 --out docs/figures/render-worm.gif && \
	$(BIN)/cpgjax render models/car.wl --time 3.5 --camera track --fps 10 --size 240x180 --out docs/figures/render-car.gif && \
	$(BIN)/cpgjax render models/quadruped.wl --ctl models/quadruped-trot.ctl --pipeline exact --terrain course:flat:0.3,stairs:0.04:0.3:3,bar:0.03,flat:1 --time 10 --camera fixed --fps 15 --size 320x240 --out docs/figures/render-stairs.gif && \
	$(BIN)/cpgjax follow models/quadruped.wl --ctl models/quadruped-walker.ctl --path figure8:0.5 --video docs/figures/follow-walker.gif
