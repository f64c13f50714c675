#!/usr/bin/env bash
# The GPU numbers the issues ask for, in one run on a lent GPU machine (no network there):
#   tools/gpu_checks.sh pack   here: release builds (stripped), Mitsuba 3 for Python 3.12 cut to
#                              the RGB variants (not with MITSUBA=0: then no step 4), the
#                              Vulkan loader's .debs, ../shared/scenes, into .gpu/ (about 40 MB,
#                              ignored by git)
#   tools/gpu_checks.sh run    there, from the checkout (carry .gpu), with OUT set:
#     1. a sanity render naming the adapter;
#     2. GPU ms per stage at 1024², 262 144 photons, depth 3 (tools/stage_times.sh), through
#        the deep cubemap, every scene of assets/suite and ../shared/scenes;
#     3. the pool example headless at 1280×720, frames per second;
#     4. `rppm bench suite` against Mitsuba's CUDA path tracer on SUB, BUDGET s each;
#     5. ours alone on REST;
#     6. (after 3) the stage times again under the BVH, to check RppmTracer::Auto's choice;
#     7. `rppm bench motion` (Reset against Reuse) on the pool's waves, a slide, an orbit, a
#        moving light, the fox and orbits of random rooms (rNN_MM), at k iterations a frame,
#        window w and seed s (MOTION: name:k:w[:s] …; rows of every run in motion.csv).
#   8. (after 6) each stage's wall time submitted alone (--profile) on ALONE (default: the suite).
#   STEPS (default "2 3 6 4 5"), SUB, REST (names in assets/suite, or random/NAME), BUDGET (4)
#   and LIMIT (seconds, 560) trim it; each step is skipped when the time left would not hold it.
#   Results: $OUT/{stage_times,suite}.md, pool.txt, log.txt. The numbers of each GPU round are
#   in the README's GPU sections (the latest: 2026-11-29, twenty-fifth stop).
set -u
here=$(pwd)
pack() {
    set -e
    local target=${CARGO_TARGET_DIR:-target} mi=/tmp/gpu_mitsuba
    mkdir -p .gpu/shared .gpu/debs
    cargo build --release -p bevy_rppm_cli --bin rppm
    cargo build --release --example pool
    cp "$target/release/rppm" /tmp/rppm.s
    cp "$target/release/examples/pool" /tmp/pool.s
    strip /tmp/rppm.s /tmp/pool.s
    pwd >.gpu/built_in
    # One dictionary over both: they share most of their code.
    tar -C /tmp -cf - rppm.s pool.s | xz --lzma2=preset=6,dict=192MiB -T1 >.gpu/bins.tar.xz
    # Mitsuba for the machine's Python 3.12, without the variants and plugins no suite scene
    # uses (the wheel is 63 MB, the checkout's carry limit 64 MiB).
    # (kept from an earlier pack: the same pinned versions)
    if [ "${MITSUBA:-1}" != 0 ] && [ ! -f .gpu/mi.tar.xz ]; then
        rm -rf $mi && mkdir -p $mi/whl
        python3 -m pip download -q --no-deps --only-binary=:all: --python-version 3.12 \
            --implementation cp --platform manylinux_2_28_x86_64 -d $mi/whl mitsuba==3.9.1 drjit==1.5.0
        (cd $mi && for w in whl/*.whl; do unzip -q -o "$w"; done && rm -rf whl share \
            mitsuba/{include,cmake,pkgconfig,mitsuba_stubs} drjit/include mitsuba/data/{sunsky,srgb.coeff} \
            mitsuba/llvm_* mitsuba/cuda_ad_{mono,spectral}* mitsuba/scalar_{mono,spectral}* &&
            find . -name '*.pyi' -delete)
        for p in aov batch blackbody blender blendphase bumpmap catmullrom checkerboard circular depth \
            direct directionalarea distant gridvolume hair heterogeneous instance irradiancemeter \
            irregular lanczos ldsampler measured measured_polarized mitchell moment multijitter \
            orthogonal plastic polarizer pplastic principled principledthin projector radiancemeter \
            rawconstant rayleigh retarder roughplastic sggx shapegroup specfilm stokes stratified \
            sunsky tabphase thinlens volpathmis ellipsoids ellipsoidsmesh bsplinecurve linearcurve \
            sdfgrid timed_sunsky volprim_rf_basic; do rm -f $mi/mitsuba/plugins/$p.so; done
        tar -C $mi -cf - . | xz --lzma2=preset=6,dict=64MiB -T1 >.gpu/mi.tar.xz
    fi
    cp ../shared/scenes/*.gltf ../shared/scenes/*.ref.exr .gpu/shared/
    # Step 7's animations: the pool's waves and the staged fox.
    mkdir -p .gpu/motion /tmp/gpu_fox && cp assets/fox/Fox.glb /tmp/gpu_fox/
    python3 tools/pool.py .gpu/motion/pool.gltf
    python3 tools/stage.py /tmp/gpu_fox/Fox.glb .gpu/motion/fox/staged.gltf
    local o="-oAPT::Architecture=amd64 -oAPT::Architectures=amd64 -oDir::State::Lists=/tmp/gpu_apt"
    mkdir -p /tmp/gpu_apt/partial && apt-get $o update -qq
    # The NVIDIA ICD (libGLX_nvidia) needs glvnd's dispatch libraries, absent on some machines.
    (cd .gpu/debs && apt-get $o download -qq libvulkan1 libglvnd0 libglx0 libegl1 libgl1 libopengl0)
    du -sh .gpu
}

run() {
    local t0 limit=${LIMIT:-560} out=${OUT:?OUT names where the results go}
    t0=$(date +%s)
    mkdir -p "$out"
    exec > >(tee "$out/log.txt") 2>&1
    want() { [[ " ${STEPS:-2 3 6 4 5} " == *" $1 "* ]]; }
    left() { echo $((limit - ($(date +%s) - t0))); }
    log() { echo "=== [$(($(date +%s) - t0)) s] $*"; }
    local b=/tmp/gpu_bin
    for f in .gpu/debs/*.deb; do dpkg -x "$f" /; done
    ldconfig
    local icd=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
    [ -f $icd ] && export VK_DRIVER_FILES=$icd
    # The binaries find assets by the path they were built in.
    local built
    built=$(cat .gpu/built_in)
    [ -e "$built" ] || { mkdir -p "$(dirname "$built")" && ln -s "$here" "$built"; }
    [ -x $b/rppm.s ] || { mkdir -p $b && tar -C $b -xJf .gpu/bins.tar.xz; }
    [ -d /tmp/gpu_mitsuba/mitsuba ] ||
        (mkdir -p /tmp/gpu_mitsuba && tar -C /tmp/gpu_mitsuba -xJf .gpu/mi.tar.xz) &
    local unpacking=$!
    nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader
    printf '#!/bin/sh\nexec timeout 90 %s/rppm.s "$@"\n' $b >$b/rppm
    chmod +x $b/rppm

    log "1. sanity"
    $b/rppm render assets/suite/closed_room.gltf --width 256 --height 256 --iterations 16 \
        --stats /tmp/gpu_sanity.json 2>&1 | grep -v WARN | tail -2
    python3 -c "import json;print(json.load(open('/tmp/gpu_sanity.json'))['adapter'])" ||
        { echo "no render: stopping"; return 1; }
    if want 2; then
        log "2. stage times"
        RPPM=$b/rppm ITERATIONS=16 tools/stage_times.sh /tmp/gpu_stages assets/suite/*.gltf \
            .gpu/shared/*.gltf -- --tracer deep-cubemap >"$out/stage_times.md" 2>&1
        cat "$out/stage_times.md"
    fi
    if want 3; then
        log "3. pool example, 1280×720"
        timeout 120 $b/pool.s --headless --width 1280 --height 720 --frames 240 2>&1 |
            grep fps | tee "$out/pool.txt"
    fi
    if want 6; then
        log "6. stage times under the BVH (RppmTracer::Auto's choice)"
        RPPM=$b/rppm ITERATIONS=16 tools/stage_times.sh /tmp/gpu_stages_bvh assets/suite/*.gltf \
            .gpu/shared/*.gltf -- --tracer bvh >"$out/stage_times_bvh.md" 2>&1
        cat "$out/stage_times_bvh.md"
    fi
    if want 8; then
        # Each stage submitted and waited for alone: its wall time, free of overlap with the
        # passes before it (to check a stage whose timestamps read high).
        log "8. wall ms per stage, each alone (--profile), under the BVH"
        RPPM=$b/rppm ITERATIONS=8 tools/stage_times.sh /tmp/gpu_stages_alone ${ALONE:-assets/suite/*.gltf} \
            -- --tracer bvh --profile >"$out/stage_times_alone.md" 2>&1
        cat "$out/stage_times_alone.md"
    fi
    if want 7; then
        log "7. motion: Reset against Reuse, iterations a frame (k) and windows (w)"
        local m=.gpu/motion small="--width 96 --height 96 --photons 32768 --frames 48"
        motion() { # name, k, w, seed, scene and flags
            local name=$1 k=$2 w=$3 seed=$4
            shift 4
            [ "$(left)" -lt 40 ] && { echo "skip $name k$k w$w s$seed: time"; return; }
            local dir=/tmp/gpu_motion/$name.k$k.w$w.s$seed
            echo "--- $name, $k iterations a frame, window $w, seed $seed"
            timeout 90 $b/rppm.s bench motion "$@" --iterations-per-frame "$k" --window "$w" \
                --seed "$seed" --every 8 --reference-iterations 64 --out $dir >$dir.log 2>&1 ||
                tail -3 $dir.log
            grep -v WARN $dir.log | grep -E "mean relMSE|lag"
            # One file of each run's rows (the tool brings back few files).
            for f in $dir/*.csv; do sed "s|^|$name,$k,$w,$seed,$(basename "$f" .csv),|" "$f"; done \
                >>"$out/motion.csv"
        }
        mkdir -p /tmp/gpu_motion
        local run
        for run in ${MOTION:-pool:1:8 pool:4:8 pool:4:32 pool:8:8 pool:8:64 slide:4:8 orbit:4:8 \
            light:4:8 fox:4:8 slide:4:32 orbit:4:32 light:4:32 fox:4:32}; do
            IFS=: read -r name k w seed <<<"$run"
            set -- "$k" "$w" "${seed:-0}"
            case $name in
            pool) motion pool "$@" $m/pool.gltf --script animation --width 128 --height 96 \
                --photons 32768 --frames 32 ;;
            slide) motion slide "$@" .gpu/shared/cornell_point.gltf --script slide \
                --object tall_box $small ;;
            orbit) motion orbit "$@" assets/cornell_box.gltf --script orbit $small ;;
            light) motion light "$@" assets/cornell_box.gltf --script light $small ;;
            fox) motion fox "$@" $m/fox/staged.gltf --script animation --animation 1 \
                --width 96 --height 96 --photons 32768 --frames 32 ;;
            r*) motion "$name" "$@" assets/suite/random/$name.gltf --script orbit $small ;;
            esac
        done
    fi
    wait $unpacking
    export PYTHONPATH=/tmp/gpu_mitsuba
    one() { # scene (a name in assets/suite, or random/NAME), then bench suite's flags
        local name=$1 dir=/tmp/gpu_one src=assets/suite
        shift
        [[ $name == */* ]] && { src=assets/suite/${name%/*} && name=${name##*/}; }
        rm -rf $dir && mkdir -p $dir && cp -r $src/textures $dir/
        cp $src/$name.gltf $src/$name.ref.exr $dir/ 2>/dev/null ||
            cp .gpu/shared/$name.gltf .gpu/shared/$name.ref.exr $dir/
        timeout 150 $b/rppm.s bench suite $dir --budget "${BUDGET:-4}" --out /tmp/gpu_suite \
            --table $dir.md "$@" >$dir.log 2>&1 || tail -5 $dir.log
        grep -A8 "Mitsuba failed" $dir.log
        [ -f "$out/suite.md" ] || head -2 $dir.md >"$out/suite.md"
        tail -1 $dir.md | tee -a "$out/suite.md"
    }
    want 4 && log "4. against Mitsuba's path tracer (cuda_ad_rgb)"
    want 4 && for name in ${SUB:-water_pool frosted_glass glass_slab cornell_glass lens_caustic \
        mirror_caustic sun_spot_caustics closed_room tinted_glass glazed_room}; do
        [ "$(left)" -lt 60 ] && { echo "skip $name: time"; continue; }
        one "$name" --variant cuda_ad_rgb
    done
    want 5 && log "5. ours alone"
    want 5 && for name in ${REST:-cornell_point frosted_lantern glossy_metal clearcoat \
        cornell_matte frosted_lamp sky_court sun_room textured_box textured_metal translucent \
        grooved_room grooved_metal lamp_globe many_lights studio texture_samplers}; do
        [ "$(left)" -lt 20 ] && { echo "skip $name: time"; continue; }
        one "$name" --no-path-tracer
    done
    log done
}

case ${1:-} in
pack) pack ;;
run) run ;;
*)
    sed -n 2,16p "$0"
    exit 2
    ;;
esac
