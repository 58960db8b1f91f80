#!/usr/bin/env bash
# Measurements of `rsm`, `rsm-interleaved` and `sii` (issue 5), printed as Markdown tables:
#   1. error against the one-bounce reference (`path`, max_bounces=1) on cornell-spot 256², and against the
#      methods' own converged value (brute-force gather of every RSM texel: no indirect occlusion);
#   2. the thesis's timing sweep as ratios interleaved / non-interleaved, for gather and for splatting;
#   3. light reaching the dark room of two-rooms, per technique and in the references.
#   4. (pointlights) cube RSMs: bumpy-glossy's three point lights, against the brute-force gather.
# Usage: scripts/measure-rsm.sh [section...]   (sections: errors pointlights timing tworooms; default: all)
# Environment: RTGI (binary, default target/release/rtgi), REF_DIR (256², 1024-spp references named
# cornell-spot-b1, two-rooms-b1, two-rooms-full .exr; default /work/refs; missing ones are rendered once with
# `rtgi reference` into $OUT/refs: slow), OUT (scratch, default target/measure-rsm).
# Timing: per-pass `steady_wall_ms` from the stats JSON (mean over frames 2..FRAMES, default 4), which leaves
# out lavapipe's lazy pipeline compilation in the first frame.
set -euo pipefail
export NODEVICE_SELECT=1
cd "$(dirname "$0")/.."
RTGI=${RTGI:-target/release/rtgi}
OUT=${OUT:-target/measure-rsm}
REF_DIR=${REF_DIR:-/work/refs}
mkdir -p "$OUT"
SECTIONS=${*:-errors pointlights timing tworooms}
FRAMES=${FRAMES:-4}

# Provenance of every table below: the command, the commit and the adapter.
commit=$(git rev-parse --short HEAD)
[[ -n "$(git status --porcelain --untracked-files=no)" ]] && commit+=" (with uncommitted changes)"
adapter=$("$RTGI" render --scene cornell-spot --technique direct --size 8x8 --out "$OUT/probe.exr" \
    --stats "$OUT/probe.json" >/dev/null 2>&1 && python3 -c 'import json, sys; print(json.load(open(sys.argv[1]))["adapter"]["name"])' "$OUT/probe.json")
echo "Printed by \`scripts/measure-rsm.sh $SECTIONS\` at commit $commit on $adapter."
echo

ref() { # name scene bounces: $REF_DIR/name.exr, else rendered once into $OUT/refs
    local f="$REF_DIR/$1.exr"
    [[ -f "$f" ]] && { echo "$f"; return; }
    mkdir -p "$OUT/refs"
    f="$OUT/refs/$1.exr"
    if [[ ! -f "$f" ]]; then
        local set=()
        [[ "$3" != "-1" ]] && set=(--set "max_bounces=$3")
        "$RTGI" reference --scene "$2" --size 256x256 --spp 1024 "${set[@]}" --out "$f" >&2
    fi
    echo "$f"
}

render() { # out scene technique frames settings...
    local out=$1 scene=$2 technique=$3 frames=$4
    shift 4
    local set=()
    for s in "$@"; do set+=(--set "$s"); done
    "$RTGI" render --scene "$scene" --technique "$technique" --size 256x256 --frames "$frames" \
        --timing passes --out "$OUT/$out.exr" --stats "$OUT/$out.json" "${set[@]}" >/dev/null 2>&1
}

cmp_json() { "$RTGI" compare "$1" "$2" --json "${@:3}"; }

if [[ " $SECTIONS " == *" errors "* ]]; then
    REF=$(ref cornell-spot-b1 cornell-spot 1)
    render bruteforce cornell-spot rsm 1 brute_force=true downsample=1
    BF=$OUT/bruteforce.exr
    render direct cornell-spot direct 1
    echo "### Error against the one-bounce reference (cornell-spot 256², 1 frame)"
    echo
    echo "FLIP / relMSE against \`path max_bounces=1\` (1024 spp); in brackets relMSE against the brute-force gather"
    echo "of all RSM texels (the methods' converged value, without indirect occlusion)."
    echo
    echo "brute-force gather vs reference: $(cmp_json "$REF" "$BF" | python3 -c 'import json,sys;m=json.load(sys.stdin);print("FLIP %.4f, relMSE %.5f" % (m["flip"], m["rel_mse"]))') —"
    echo "the error no sample count removes (missing indirect visibility, RSM discretisation, the clamp of d² at the texel area)."
    echo "direct only vs reference: $(cmp_json "$REF" "$OUT/direct.exr" | python3 -c 'import json,sys;m=json.load(sys.stdin);print("FLIP %.4f, relMSE %.5f" % (m["flip"], m["rel_mse"]))')."
    echo
    echo "| technique | settings | 64 | 256 | 1024 |"
    echo "|---|---|---|---|---|"
    while IFS='|' read -r technique count_key settings; do
        row="| $technique | ${settings:-defaults} |"
        for n in 64 256 1024; do
            name="err-$technique-${settings// /_}-$n"
            name=${name//=/}
            # shellcheck disable=SC2086
            render "$name" cornell-spot "$technique" 1 "$count_key=$n" $settings
            row+=" $(python3 - "$(cmp_json "$REF" "$OUT/$name.exr")" "$(cmp_json "$BF" "$OUT/$name.exr")" <<'PY'
import json, sys
r, b = json.loads(sys.argv[1]), json.loads(sys.argv[2])
print("%.4f / %.5f (%.5f)" % (r["flip"], r["rel_mse"], b["rel_mse"]))
PY
) |"
        done
        echo "$row"
    done <<'ROWS'
rsm|samples|
rsm|samples|weighting=xi2
rsm|samples|downsample=1
rsm-interleaved|samples|interleave=2x2
rsm-interleaved|samples|interleave=4x4
rsm-interleaved|samples|interleave=8x8
sii|vpls|
sii|vpls|interleave=2x2
sii|vpls|interleave=4x4
sii|vpls|interleave=8x8
sii|vpls|interleave=2x2 rescale=false
sii|vpls|interleave=4x4 rescale=false
sii|vpls|interleave=8x8 rescale=false
ROWS
    echo
fi

if [[ " $SECTIONS " == *" pointlights "* ]]; then
    echo "### Point lights (cube RSMs): bumpy-glossy 128², RSM 64² × 6 faces × 3 lights"
    echo
    echo "Against the brute-force gather of all 73,728 texels (the converged value; no path-traced one-bounce"
    echo "reference of this scene was rendered): relMSE, and the mean luminance over the image as a ratio."
    echo
    "$RTGI" render --scene bumpy-glossy --technique rsm --size 128x128 --set brute_force=true --set downsample=1 \
        --set rsm_size=64 --out "$OUT/pl-bf.exr" >/dev/null 2>&1
    "$RTGI" render --scene bumpy-glossy --technique direct --size 128x128 --out "$OUT/pl-direct.exr" >/dev/null 2>&1
    echo "| technique | 64 | 256 | 1024 |"
    echo "|---|---|---|---|"
    row="| direct |"
    for n in 64 256 1024; do
        row+=" $(cmp_json "$OUT/pl-bf.exr" "$OUT/pl-direct.exr" --region 0,0,128,128 | python3 -c '
import json, sys
m = json.load(sys.stdin)
print("%.4f (%.3f)" % (m["rel_mse"], m["region"]["test_luminance"] / m["region"]["reference_luminance"]))') |"
    done
    echo "$row"
    for t in "rsm|samples" "sii|vpls"; do
        technique=${t%%|*}
        key=${t#*|}
        row="| $technique |"
        for n in 64 256 1024; do
            "$RTGI" render --scene bumpy-glossy --technique "$technique" --size 128x128 --set rsm_size=64 \
                --set "$key=$n" --out "$OUT/pl-$technique-$n.exr" >/dev/null 2>&1
            row+=" $(cmp_json "$OUT/pl-bf.exr" "$OUT/pl-$technique-$n.exr" --region 0,0,128,128 | python3 -c '
import json, sys
m = json.load(sys.stdin)
print("%.4f (%.3f)" % (m["rel_mse"], m["region"]["test_luminance"] / m["region"]["reference_luminance"]))') |"
        done
        echo "$row"
    done
    echo
fi

# Steady per-frame wall ms (frames after the first) of the passes $2.. in stats file $OUT/$1.json.
window_ms() {
    python3 - "$OUT/$1.json" "${@:2}" <<'PY'
import json, sys
passes = {p["name"]: p for p in json.load(open(sys.argv[1]))["passes"]}
print("%.2f" % sum(passes[n]["steady_wall_ms"] for n in sys.argv[2:] if n in passes))
PY
}

if [[ " $SECTIONS " == *" timing "* ]]; then
    echo "### Timing sweep: interleaved / non-interleaved (256², RSM 256², mean of frames 2–$FRAMES, lavapipe wall time)"
    echo
    echo "Window as in the thesis: after RSM generation to after the blur. Gather: split + gather + merge +"
    echo "discontinuity filter over the non-interleaved full-resolution gather; splatting: split + splat + merge +"
    echo "filter over the non-interleaved splat (VPL selection, common to both, excluded). In brackets: the"
    echo "gather or splat pass alone over its non-interleaved time. First column: non-interleaved ms."
    echo
    for kind in gather splat; do
        echo "**$kind**"
        echo
        echo "| count | 1x1 ms | 2x2 | 2x4 | 4x4 | 8x8 |"
        echo "|---|---|---|---|---|---|"
        for n in 64 128 256 512 768 1024; do
            if [[ $kind == gather ]]; then
                base_args=(rsm samples=$n downsample=1); passes=("rsm gather"); core="rsm gather"
            else
                base_args=(sii vpls=$n); passes=("splat"); core="splat"
            fi
            render "t-$kind-$n-1x1" cornell-spot "${base_args[0]}" $FRAMES "${base_args[@]:1}"
            base=$(window_ms "t-$kind-$n-1x1" "${passes[@]}")
            row="| $n | $base |"
            for p in 2x2 2x4 4x4 8x8; do
                if [[ $kind == gather ]]; then args=(rsm-interleaved samples=$n interleave=$p); else args=(sii vpls=$n interleave=$p); fi
                render "t-$kind-$n-$p" cornell-spot "${args[0]}" $FRAMES "${args[@]:1}"
                win=$(window_ms "t-$kind-$n-$p" split "$core" merge "discontinuity filter")
                c=$(window_ms "t-$kind-$n-$p" "$core")
                row+=" $(python3 -c "print('%.1f %% (%.1f %%)' % (100*$win/$base, 100*$c/$base))") |"
            done
            echo "$row"
        done
        echo
    done
fi

if [[ " $SECTIONS " == *" tworooms "* ]]; then
    B1=$(ref two-rooms-b1 two-rooms 1)
    # The all-bounce reference is optional (slow): used when present in $REF_DIR or with TWO_ROOMS_FULL=1.
    FULL=$REF_DIR/two-rooms-full.exr
    if [[ ! -f "$FULL" ]]; then
        if [[ "${TWO_ROOMS_FULL:-0}" == 1 ]]; then FULL=$(ref two-rooms-full two-rooms -1); else FULL=""; fi
    fi
    echo "### Light in the dark room of two-rooms (256², 1024 samples / VPLs)"
    echo
    echo "Mean luminance (linear radiance) in pixel rectangles that show only room 2 (the camera's room): its floor"
    echo "(0,200,256,56), the ceiling strip (0,0,230,15) and the far right wall (240,60,16,120). The spot cannot"
    echo "reach room 2, so all of it is indirect light; in the references it enters through the doorway only."
    echo "In brackets: the ratio to the one-bounce reference."
    echo
    REGIONS=(0,200,256,56 0,0,230,15 240,60,16,120)
    echo "| image | floor | ceiling | right wall |"
    echo "|---|---|---|---|"
    render tr-bruteforce two-rooms rsm 1 brute_force=true downsample=1 rsm_size=128
    render tr-direct two-rooms direct 1
    render tr-rsm two-rooms rsm 1 samples=1024
    render tr-rsm15 two-rooms rsm 1 samples=1024 r_max=1.5
    render tr-rsmi two-rooms rsm-interleaved 1 samples=1024 interleave=4x4
    render tr-sii two-rooms sii 1 vpls=1024
    render tr-siii two-rooms sii 1 vpls=1024 interleave=4x4
    render tr-siin two-rooms sii 1 vpls=1024 interleave=4x4 rescale=false
    entries=("path max_bounces=1 (reference)|$B1")
    [[ -n "$FULL" ]] && entries+=("path, all bounces|$FULL")
    for entry in "${entries[@]}" "direct|$OUT/tr-direct.exr" \
        "rsm brute force (rsm_size 128): no indirect occlusion|$OUT/tr-bruteforce.exr" "rsm 1024|$OUT/tr-rsm.exr" \
        "rsm 1024, r_max=1.5|$OUT/tr-rsm15.exr" "rsm-interleaved 4x4 1024|$OUT/tr-rsmi.exr" "sii 1024|$OUT/tr-sii.exr" \
        "sii 4x4 1024|$OUT/tr-siii.exr" "sii 4x4 1024 rescale=false|$OUT/tr-siin.exr"; do
        label=${entry%%|*}
        img=${entry#*|}
        row="| $label |"
        for r in "${REGIONS[@]}"; do
            row+=" $(cmp_json "$B1" "$img" --region "$r" | python3 -c '
import json, sys
g = json.load(sys.stdin)["region"]
t, r = g["test_luminance"], g["reference_luminance"]
print("%.5f (%s)" % (t, "%.2f" % (t / r) if r > 0 else "-"))') |"
        done
        echo "$row"
    done
    echo
fi
