#!/usr/bin/env bash
# Runs the AFL++ fuzz targets (cargo-afl) for SECONDS each, two at a time, and fails if any
# found a crash or a hang. Usage: fuzz/run.sh SECONDS [TARGET...] (default: every target).
# Installs cargo-afl and builds its AFL++ runtime when they are missing. Findings go to
# fuzz/out/TARGET/default/{crashes,hangs}; each target's log to fuzz/out/TARGET.log.
set -euo pipefail
cd "$(dirname "$0")"
secs=${1:-600}
shift || true
targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
    targets=(mesh_off mesh_obj mesh_ply mesh_stl mesh_gltf mesh_xyz mesh_pts mesh_pcd index_segment index_manifest index_search_cache map_file surface_off)
fi

if ! cargo afl --version >/dev/null 2>&1; then
    cargo install cargo-afl --locked
fi
if ! cargo afl config --build >/dev/null 2>&1; then
    # Already built for this toolchain is reported as an error too: check by building.
    true
fi
cargo afl build --release --bins

export AFL_NO_UI=1 AFL_SKIP_CPUFREQ=1 AFL_I_DONT_CARE_ABOUT_MISSING_CRASHES=1 \
    AFL_NO_AFFINITY=1 AFL_QUIET=1
mkdir -p out
fuzz_one() {
    local t=$1
    rm -rf "out/$t"
    # -V: stop after this many seconds; -t: a run taking longer than 2 s is a hang.
    cargo afl fuzz -i "seeds/$t" -o "out/$t" -V "$secs" -t 2000 "target/release/$t" \
        >"out/$t.log" 2>&1 || { echo "$t: afl-fuzz failed, see fuzz/out/$t.log"; tail -20 "out/$t.log"; return 1; }
}
status=0
for ((i = 0; i < ${#targets[@]}; i += 2)); do
    pids=()
    for t in "${targets[@]:i:2}"; do
        fuzz_one "$t" &
        pids+=($!)
    done
    for p in "${pids[@]}"; do
        wait "$p" || status=1
    done
done
for t in "${targets[@]}"; do
    stats="out/$t/default/fuzzer_stats"
    execs=$(awk -F: '/^execs_done/ {gsub(/ /, "", $2); print $2}' "$stats" 2>/dev/null || echo "?")
    paths=$(awk -F: '/^corpus_count/ {gsub(/ /, "", $2); print $2}' "$stats" 2>/dev/null || echo "?")
    crashes=$(find "out/$t/default/crashes" -type f ! -name README.txt 2>/dev/null | wc -l)
    hangs=$(find "out/$t/default/hangs" -type f 2>/dev/null | wc -l)
    echo "$t: ${secs} s, $execs runs, corpus $paths, crashes $crashes, hangs $hangs"
    if [ "$crashes" -ne 0 ] || [ "$hangs" -ne 0 ]; then
        status=1
    fi
done
exit $status
