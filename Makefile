# The two commands of the README. Both install Debian's HDF5 library (and h5py, which a
# test uses to read our files from Python) when pkg-config cannot find it, and the DejaVu
# font the pictures are drawn with when it is missing.

.PHONY: run test python deps

# The Python module's virtual environment, and what its tests and examples import.
VENV := $(CURDIR)/target/venv
PYTHON_PACKAGES := maturin numpy pytest pandas matplotlib h5py tqdm

# The main job: the thick-walled cylinder test from sample preparation to breakout.
run: deps
	cargo run --release -- generate examples/cylinder-sample.toml -o samples/cylinder-1000.h5
	cargo run --release -- run examples/cylinder-test.toml

# The whole test suite, plus the formatting, lint and documentation checks (of the Python
# module's crate too), then the Python module's tests and examples.
test: deps
	cargo fmt --all --check
	cargo clippy --workspace --all-targets -- -D warnings
	RUSTDOCFLAGS="-D warnings" cargo doc --no-deps --workspace
	cargo test --release
	$(MAKE) python

# The Python module built into a virtual environment under target/ (the packages it needs
# installed from PyPI when missing), its pytest suite run, the examples among it.
python: deps
	cargo build --release
	@test -x $(VENV)/bin/python || python3 -m venv $(VENV)
	@test -x $(VENV)/bin/maturin && $(VENV)/bin/python -c "import numpy, pytest, pandas, matplotlib, h5py, tqdm" 2>/dev/null \
		|| $(VENV)/bin/pip install -q $(PYTHON_PACKAGES)
	VIRTUAL_ENV=$(VENV) PATH="$(VENV)/bin:$$PATH" maturin develop --release -q -m python/Cargo.toml
	cd python && $(VENV)/bin/python -m pytest tests

deps:
	@if ! pkg-config --exists hdf5 2>/dev/null || ! /usr/bin/python3 -c "import h5py" 2>/dev/null; then \
		echo "installing libhdf5-dev, pkg-config and python3-h5py with apt-get"; \
		apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq \
			libhdf5-dev pkg-config python3-h5py >/dev/null; \
	fi
	@if [ ! -f /usr/share/fonts/truetype/dejavu/DejaVuSans.ttf ]; then \
		echo "installing fonts-dejavu-core with apt-get"; \
		apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq \
			fonts-dejavu-core >/dev/null; \
	fi
