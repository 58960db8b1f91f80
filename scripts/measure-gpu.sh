#!/usr/bin/env bash
# Takes the open issues' GPU figures in one go on a machine with a discrete GPU that receives a copy of this
# checkout packed by ../shared/tools/gpu-pack.sh (the release binary and the test binaries in .gpu/). Here:
#     ../shared/tools/gpu-pack.sh && bash scripts/measure-gpu.sh --pack [--no-tests] [--no-base]
# (--pack strips the binaries, adds traversal's "before" build, target/traversal-base/target/release/rtgi,
# which `python3 scripts/measure-traversal.py` builds, and compresses them as one solid archive of about
# 17 MiB; --no-tests leaves the test binaries out (about 6 MiB left), --no-base the "before" build. The
# device machine takes 64 MiB with the tracked files, of which docs/ alone hold about 45: pack the tests
# and the "before" build for separate calls when both do not fit). There, in the copy's root:
#     bash scripts/measure-gpu.sh STEP...
# Steps, run in the order given, each under its own time limit (seconds after a colon, e.g. splat:120):
#     traversal  issue 15.1  scripts/measure-traversal.py --size 1920x1080 --doc traversal-gpu (against .gpu/base/rtgi)
#     primary    issue 15.2  scripts/measure-primary.py --size 1920x1080 --doc primary-gpu
#     splat      issue 15.3  scripts/measure-splat.py --size 1920x1080 --doc splat-gpu
#     vpl        issue 15.4  scripts/measure-vpl-equal-time.py --size 1920x1080 --doc vpl-equal-time-gpu
#     ddgi       issue 12    scripts/measure-ddgi.py --suite benches/ddgi-gpu.toml --doc ddgi-gpu --no-lag
#     ddgi-256   issue 12    scripts/measure-ddgi.py --size 256x256 --doc ddgi-256 (the 128² suite at 256², with the lag runs)
#     lpv, vxgi  issue 11    scripts/measure-lpv.py / measure-vxgi.py --size 1920x1080 --doc lpv-gpu / vxgi-gpu
#     vxgi-scroll  issue 11  scripts/measure-scroll.py --size 1920x1080 --timing frame --doc vxgi-scroll-gpu
#     radiance-cache  issue 13  scripts/measure-radiance-cache.py --size 1920x1080 --doc radiance-cache-gpu
#     motion-blur  (no issue)  scripts/measure-motion-blur.py --size 1920x1080 --doc motion-blur-gpu
#     subsurface   (no issue)  scripts/measure-subsurface.py --sizes 1920x1080 --doc subsurface-gpu
#     glints       (no issue)  scripts/measure-glints.py --sizes 1920x1080 --doc glints-gpu
#     glints-environment  (no issue)  scripts/measure-glints-environment.py --size 1920x1080 --doc glints-environment-gpu
#     subsurface-truth  (no issue)  scripts/measure-subsurface-truth.py --size 512x512 --spp 65536 --doc subsurface-truth-gpu
#     tests      the whole test suite (.gpu/test.sh)
# The documents land in docs/measurements/ as on any machine; with $OUT set (the device tool's folder that
# comes back) those the run wrote are packed after every step into $OUT/measurements.tgz, with the log in $OUT/log.txt,
# so a step stopped by its limit still returns what the others printed. DEADLINE=S (seconds from the
# start) shortens every step's limit to what is left of S, and skips the steps it leaves no time for.
set -uo pipefail
cd "$(dirname "$0")/.."
if [ "${1:-}" = --pack ]; then
    set -e
    tests=yes; with_base=yes
    for option in "${@:2}"; do
        case $option in
            --no-tests) tests=no ;;
            --no-base) with_base=no ;;
            *) echo "unknown option $option" >&2; exit 1 ;;
        esac
    done
    base=target/traversal-base/target/release/rtgi
    if [ $with_base = yes ] && [ ! -x "$base" ]; then
        echo "no $base: run python3 scripts/measure-traversal.py once to build it, or pass --no-base" >&2; exit 1
    fi
    stage=$(mktemp -d); trap 'rm -rf "$stage"' EXIT
    # gpu-pack's list of test binaries, kept whole for later packs (tests.txt lists what this one holds).
    [ -s .gpu/tests-all.txt ] || cp .gpu/tests.txt .gpu/tests-all.txt
    bins=(target/release/rtgi)
    [ $tests = yes ] && bins+=($(cut -f1 .gpu/tests-all.txt))
    for b in "${bins[@]}"; do mkdir -p "$stage/$(dirname "$b")"; cp "$b" "$stage/$b"; done
    mkdir -p "$stage/.gpu"
    if [ $with_base = yes ]; then mkdir -p "$stage/.gpu/base"; cp "$base" "$stage/.gpu/base/rtgi"; fi
    find "$stage" -type f -exec strip {} +
    if [ $tests = yes ]; then cp .gpu/tests-all.txt .gpu/tests.txt; else : > .gpu/tests.txt; fi
    # One solid stream with a dictionary larger than all binaries together: they share most of their code.
    (cd "$stage" && tar cf - target .gpu) | xz -T1 --lzma2=preset=9e,dict=1536MiB > .gpu/bins.txz
    # The commit the binaries were built from, for the documents (the copy there has no history of its own).
    git describe --always --dirty --abbrev=12 > .gpu/commit.txt
    echo "repacked .gpu/bins.txz: $(du -h .gpu/bins.txz | cut -f1)"
    exit 0
fi
source .gpu/setup.sh
export RTGI="$here/target/release/rtgi" RTGI_BASE="$here/.gpu/base/rtgi" RTGI_BASE_COMMIT=2ffd778
export PYTHONUNBUFFERED=1
# The documents name the packed commit. A .git in the copy is not that commit's (the device machine's copy
# of the tree may come with the repository as it was earlier), so the scripts must not ask it.
if [ -s .gpu/commit.txt ]; then
    export RTGI_COMMIT=$(cat .gpu/commit.txt)
    [ -d .git ] && mv .git .gpu/copied-git
fi
out=${OUT:-$here/.gpu/out}; mkdir -p "$out"
log="$out/log.txt"
nvidia-smi -L >> "$log" 2>&1

# What the steps print: the documents and bench folders written after this marker (ddgi-256 included,
# whose name has no -gpu; the committed documents the steps do not touch stay behind).
marker=$(mktemp); touch "$marker"
pack() {
    local printed
    printed=$(cd docs/measurements && find . -mindepth 1 -maxdepth 1 -newer "$marker" | sort)
    [ -n "$printed" ] && (cd docs/measurements && tar czf "$out/measurements.tgz" $printed)
}

begun=$(date +%s)
for step in "$@"; do
    name=${step%%:*}; limit=${step#*:}; [ "$limit" = "$step" ] && limit=600
    if [ -n "${DEADLINE:-}" ]; then
        left=$(( DEADLINE - ($(date +%s) - begun) ))
        [ "$left" -lt "$limit" ] && limit=$left
        [ "$limit" -lt 10 ] && { echo "== $name: skipped, the deadline is near" >> "$log"; continue; }
    fi
    case $name in
        traversal) cmd=(python3 scripts/measure-traversal.py --size 1920x1080 --doc traversal-gpu --rounds 2) ;;
        primary) cmd=(python3 scripts/measure-primary.py --size 1920x1080 --doc primary-gpu --rounds 2) ;;
        splat) cmd=(python3 scripts/measure-splat.py --size 1920x1080 --doc splat-gpu) ;;
        vpl) cmd=(python3 scripts/measure-vpl-equal-time.py --size 1920x1080 --doc vpl-equal-time-gpu) ;;
        ddgi) cmd=(python3 scripts/measure-ddgi.py --suite benches/ddgi-gpu.toml --doc ddgi-gpu --no-lag) ;;
        ddgi-256) cmd=(python3 scripts/measure-ddgi.py --size 256x256 --doc ddgi-256) ;;
        lpv) cmd=(python3 scripts/measure-lpv.py --size 1920x1080 --doc lpv-gpu) ;;
        vxgi) cmd=(python3 scripts/measure-vxgi.py --size 1920x1080 --doc vxgi-gpu) ;;
        vxgi-scroll) cmd=(python3 scripts/measure-scroll.py --size 1920x1080 --timing frame --doc vxgi-scroll-gpu) ;;
        radiance-cache) cmd=(python3 scripts/measure-radiance-cache.py --size 1920x1080 --doc radiance-cache-gpu) ;;
        motion-blur) cmd=(python3 scripts/measure-motion-blur.py --size 1920x1080 --doc motion-blur-gpu) ;;
        subsurface) cmd=(python3 scripts/measure-subsurface.py --sizes 1920x1080 --doc subsurface-gpu) ;;
        glints) cmd=(python3 scripts/measure-glints.py --sizes 1920x1080 --doc glints-gpu) ;;
        glints-environment) cmd=(python3 scripts/measure-glints-environment.py --size 1920x1080 --doc glints-environment-gpu) ;;
        subsurface-truth) cmd=(python3 scripts/measure-subsurface-truth.py --size 512x512 --spp 65536 --doc subsurface-truth-gpu) ;;
        tests) rm -rf .gpu/test-out; cmd=(env OUT="$here/.gpu/test-out" bash .gpu/test.sh) ;;
        *) echo "unknown step $name" >> "$log"; continue ;;
    esac
    started=$(date +%s)
    echo "== $name (limit ${limit} s): ${cmd[*]}" >> "$log"
    timeout "$limit" "${cmd[@]}" >> "$log" 2>&1
    echo "== $name: exit $? after $(( $(date +%s) - started )) s" >> "$log"
    if [ "$name" = tests ]; then
        # Logs of a run stopped by its limit are still loose files: one archive and the summary come back.
        (cd .gpu/test-out && cp summary.txt "$out/" && tar czf "$out/tests.tgz" $(ls test-*.log tests.tgz 2>/dev/null))
    fi
    pack
done
tail -n 40 "$log"
