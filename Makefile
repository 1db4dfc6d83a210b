# Two commands on a fresh Debian bookworm machine: `make demo`, `make test`.
SHELL := /bin/bash
# catkin's configure breaks under the pyenv python3 that comes first in PATH on
# our machines; Debian's own python3 has catkin_pkg, empy and rospkg.
export PATH := /usr/bin:/bin:$(PATH)
export ROS_LOG_DIR ?= $(CURDIR)/build/ros_log

BUILD_DIR := build
JOBS ?= $(shell nproc)
BUILD_TYPE ?= RelWithDebInfo

.PHONY: all deps build test demo bench clean

all: build

deps:
	@./scripts/install_deps.sh

$(BUILD_DIR)/CMakeCache.txt: CMakeLists.txt package.xml
	cmake -S . -B $(BUILD_DIR) -DCMAKE_BUILD_TYPE=$(BUILD_TYPE) \
	  -DPYTHON_EXECUTABLE=/usr/bin/python3 \
	  -DCATKIN_DEVEL_PREFIX=$(CURDIR)/$(BUILD_DIR)/devel \
	  -DCATKIN_ENABLE_TESTING=ON

build: deps $(BUILD_DIR)/CMakeCache.txt
	cmake --build $(BUILD_DIR) -j $(JOBS)

test: build
	@./scripts/run_tests.sh $(BUILD_DIR)

demo: build
	@./scripts/demo.sh $(BUILD_DIR)

bench: build
	@./scripts/bench.sh $(BUILD_DIR)

clean:
	rm -rf $(BUILD_DIR)
