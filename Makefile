# The two commands of the README. Both install Debian's HDF5 library (and h5py, which a
# test uses to read our files from Python) when pkg-config cannot find it, and the DejaVu
# font the pictures are drawn with when it is missing.

.PHONY: run test deps

# The main job: the thick-walled cylinder test from sample preparation to breakout.
run: deps
	cargo run --release -- generate examples/cylinder-sample.toml -o samples/cylinder-1000.h5
	cargo run --release -- run examples/cylinder-test.toml

# The whole test suite, plus the formatting, lint and documentation checks.
test: deps
	cargo fmt --check
	cargo clippy --all-targets -- -D warnings
	RUSTDOCFLAGS="-D warnings" cargo doc --no-deps
	cargo test --release

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
