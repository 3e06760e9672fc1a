# The two commands of the README: `make demo` (the main job) and `make test` (every test).
# Each one sets everything up first (scripts/setup.sh). `make lab` opens the notebooks; `make book` renders them.
PY := .venv/bin/python
export PYOPENGL_PLATFORM ?= egl

SCENE ?= scene1
PLANNER ?= stair
SEED ?= 0
OUT ?= runs/demo
RUN_FLAGS ?= --overwrite

.PHONY: setup setup-browser demo test unit notebooks lab book bench student grade

setup:
	@bash scripts/setup.sh

setup-browser:  # also Debian's chromium, for the book's browser check
	@STAIR_BROWSER=1 bash scripts/setup.sh

demo: setup
	$(PY) -m stair_lite run --scene $(SCENE) --planner $(PLANNER) --seed $(SEED) --out $(OUT) $(RUN_FLAGS)

# every notebook runs once: its executed copy (build/executed/) is what the book's test, run last, builds
test: setup-browser
	STAIR_BOOK_REQUIRED=1 $(PY) -m pytest tests notebooks --nbval-lax --nbval-current-env --nbval-cell-timeout=600 --durations=15 -ra

unit: setup
	$(PY) -m pytest tests -ra -m "not release"

notebooks: setup
	$(PY) -m pytest notebooks --nbval-lax --nbval-current-env --nbval-cell-timeout=600 --durations=15 -ra

book: setup  # the executed notebooks as a static HTML site in build/book/html (README, "The book")
	$(PY) -m stair_lite.book

lab: setup
	MPLBACKEND=module://matplotlib_inline.backend_inline .venv/bin/jupyter lab notebooks

# The course edition (README, "Teaching with the notebooks"): the student release, and grading a folder of
# submissions (SUBMISSIONS/<student>/<notebook>.ipynb) into a table of points.
STUDENT ?= student
SUBMISSIONS ?= submissions
GRADES ?= grades.csv

student: setup
	$(PY) -m stair_lite.course student --out $(STUDENT)

grade: setup
	$(PY) -m stair_lite.course grade $(SUBMISSIONS) --out $(GRADES)

bench: setup
	$(PY) benchmarks/bench_world.py
