# Two commands on a fresh Debian bookworm machine: `make demo`, `make test`.
SHELL := /bin/bash
# catkin's configure breaks under the pyenv python3 that comes first in PATH on
# our machines; Debian's own python3 has catkin_pkg, empy and rospkg.
export PATH := /usr/bin:/bin:$(PATH)
export ROS_LOG_DIR ?= $(CURDIR)/build/ros_log

BUILD_DIR := build
# The catkin devel space sits outside build/: rosrun skips every path under
# <package>/build/, so a devel space there hides the tools from `rosrun`.
DEVEL_DIR := devel
export RELOCALIZER_DEVEL := $(CURDIR)/$(DEVEL_DIR)
JOBS ?= $(shell nproc)
BUILD_TYPE ?= RelWithDebInfo
# Unit tests under AddressSanitizer + UndefinedBehaviorSanitizer, and the
# libFuzzer targets (docs/reliability.md); each in its own build folder.
# Under build/, so rosrun never sees their tools beside the devel space.
ASAN_BUILD_DIR := build/asan
# -O1 and line tables only: sanitizer reports keep file:line, and the build
# takes half the time of -O3 -g. NDEBUG as in `build`, so the same code runs.
ASAN_CXX_FLAGS := -O1 -g1 -DNDEBUG
FUZZ_SECONDS ?= 60

.PHONY: all deps build test demo bench bench-places bench-changes bench-heal clean test-asan fuzz test-workspaces

all: build

deps:
	@./scripts/install_deps.sh

# A stamp written only when configure succeeds: cmake leaves a CMakeCache.txt
# behind a failed configure, and a user who then installs what was missing must
# get a new configure from the same `make demo`, not a stale build folder.
CONFIGURED := .relocalizer-configured
CMAKE_INPUTS := CMakeLists.txt package.xml $(wildcard cmake/*.cmake)

$(BUILD_DIR)/$(CONFIGURED): $(CMAKE_INPUTS)
	cmake -S . -B $(BUILD_DIR) -DCMAKE_BUILD_TYPE=$(BUILD_TYPE) \
	  -DPYTHON_EXECUTABLE=/usr/bin/python3 \
	  -DCATKIN_DEVEL_PREFIX=$(CURDIR)/$(DEVEL_DIR) \
	  -DCATKIN_ENABLE_TESTING=ON
	touch $@

build: deps $(BUILD_DIR)/$(CONFIGURED)
	cmake --build $(BUILD_DIR) -j $(JOBS)

test: build
	@./scripts/run_tests.sh $(BUILD_DIR)

demo: build
	@./scripts/demo.sh $(BUILD_DIR)

# The same catkin configure as `build`, with the sanitizers on and ASAN_CXX_FLAGS.
$(ASAN_BUILD_DIR)/$(CONFIGURED): $(CMAKE_INPUTS)
	cmake -S . -B $(ASAN_BUILD_DIR) -DCMAKE_BUILD_TYPE=Asan \
	  -DCMAKE_CXX_FLAGS_ASAN="$(ASAN_CXX_FLAGS)" \
	  -DPYTHON_EXECUTABLE=/usr/bin/python3 \
	  -DCATKIN_DEVEL_PREFIX=$(CURDIR)/$(ASAN_BUILD_DIR)/devel \
	  -DCATKIN_ENABLE_TESTING=ON -DRELOCALIZER_SANITIZE=ON
	touch $@

test-asan: deps $(ASAN_BUILD_DIR)/$(CONFIGURED)
	@JOBS=$(JOBS) ./scripts/test_asan.sh $(ASAN_BUILD_DIR)

# The README's catkin workspace commands (catkin_make, catkin build, the install
# space) in a new workspace of their own: two more builds, so not in `make test`.
test-workspaces: deps
	@./scripts/test_workspaces.sh

# Standalone clang build of test/fuzz/ (no catkin); FUZZ_SECONDS per target.
fuzz: deps
	@JOBS=$(JOBS) FUZZ_SECONDS=$(FUZZ_SECONDS) ./scripts/fuzz.sh

bench: build
	@./scripts/bench.sh $(BUILD_DIR)

# Many places in one node: latency, wrong places and memory with 10 places.
bench-places: build
	@./scripts/bench_places.sh $(BUILD_DIR)

# The world changed after training: other light, people, furniture and lamps on the test
# frames; the default model beside config/light_augmented.yaml's (~30 min).
bench-changes: build
	@./scripts/bench_changes.sh $(BUILD_DIR)

# A learned place, and one made by `train`, heal after furniture moved (~15 min).
bench-heal: build
	@./scripts/bench_heal.sh $(BUILD_DIR)

clean:
	rm -rf $(BUILD_DIR) $(DEVEL_DIR)
