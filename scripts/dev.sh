#!/usr/bin/env bash
# wormdrag developer entry point: installs the Debian packages it needs (only those
# missing), configures and builds, then runs what was asked.
#
#   scripts/dev.sh example   estimate the bundled example pair, embedded in one process
#   scripts/dev.sh test      run the whole test suite (ctest)
#   scripts/dev.sh build     only install and build
#   scripts/dev.sh fuzz [S]  run every fuzz target S seconds (scripts/fuzz.sh; clang, ASan+UBSan)
#   scripts/dev.sh lint      clang-format check of the tracked sources, then a -Werror build
#                            in LINT_BUILD_DIR (default build-lint)
#
# Environment: BUILD_DIR (default build), LINT_BUILD_DIR (default build-lint), JOBS
# (default: number of cores).
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
build_dir=${BUILD_DIR:-build}
lint_build_dir=${LINT_BUILD_DIR:-build-lint}
jobs=${JOBS:-$(nproc)}

# Debian packages (Debian 12). The reason for each non-obvious one is in README.md.
packages=(
  cmake ninja-build g++ pkg-config
  libeigen3-dev libnlopt-dev libnlopt-cxx-dev libsqlite3-dev libspdlog-dev libfmt-dev
  libgrpc++-dev libprotobuf-dev protobuf-compiler protobuf-compiler-grpc
  libopencv-dev libmatio-dev libhdf5-dev nlohmann-json3-dev libcpp-httplib-dev
  libgtest-dev libgmock-dev googletest libbenchmark-dev
  unzip chromium openssl systemd python3 python3-yaml slurm-wlm munge
  clang libclang-rt-dev
)
# Only `lint` needs these; the Docker build stage installs the list above.
lint_packages=(clang-format)

# Installs the packages above and any named as arguments, those missing only.
install_packages() {
  local missing=()
  for p in "${packages[@]}" "$@"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  [ ${#missing[@]} -eq 0 ] && return 0
  echo "dev.sh: installing ${missing[*]}" >&2
  local sudo=""
  [ "$(id -u)" -ne 0 ] && sudo="sudo"
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
}

build() {
  install_packages
  cmake -S "$root" -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
  cmake --build "$build_dir" -j "$jobs"
}

# Every tracked C++ source is ours to format: protoc's output lives in the build tree.
lint() {
  install_packages "${lint_packages[@]}"
  echo "dev.sh: clang-format --dry-run --Werror (.clang-format)" >&2
  git ls-files -z '*.cc' '*.h' | xargs -0 clang-format --dry-run --Werror
  echo "dev.sh: -Werror build in $lint_build_dir" >&2
  cmake -S "$root" -B "$lint_build_dir" -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_FLAGS=-Werror >/dev/null
  cmake --build "$lint_build_dir" -j "$jobs"
}

case "${1:-}" in
  build)
    build
    ;;
  example)
    build
    db=${WORMDRAG_DB:-$build_dir/example.db}
    echo "dev.sh: estimating examples/data/L1.csv + L2.csv (store: $db)" >&2
    # The default smoothing leaves this noise-free pair unchanged (docs/estimation.md).
    "$build_dir/client/wormdrag" estimate examples/data/L1.csv examples/data/L2.csv --db "$db" "${@:2}"
    ;;
  test)
    build
    ctest --test-dir "$build_dir" --output-on-failure -j "$jobs" --timeout 900
    ;;
  lint)
    lint
    ;;
  fuzz)
    install_packages
    bash scripts/fuzz.sh "${@:2}"
    ;;
  *)
    echo "usage: scripts/dev.sh example|test|build|lint|fuzz [options]" >&2
    exit 2
    ;;
esac
