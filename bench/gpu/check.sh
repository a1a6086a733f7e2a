#!/bin/bash
# GPU check: the opencl render device on an NVIDIA GPU against the CPU device of the same machine.
# Runs from the repository root with .devkit/ made by bench/gpu/make_kit.sh (the binaries and their
# libraries, started through the packed loader so the host's libraries do not matter). Renders the
# SDF scenes with path and bdpt on both devices (RES, SPP, SPB, T threads; the CPU with
# --specular-nee none, the device's estimator), prints samples per second and `specula diff`'s ratio
# of means and z-test, writes the EXRs to $OUT, then runs test_opencl (TT seconds at most). With
# .devkit/specula_old (another build), its opencl bdpt renders too, for a before/after.
# The NVIDIA OpenCL driver is found with ldconfig or under / and given to the ICD loader alone.
K=$PWD/.devkit; O=${OUT:-/tmp/devout}; mkdir -p $O
(cd $K && tar xJf lib.tar.xz)
L=$K/lib
nvidia-smi -L 2>&1 | head -2
NV=$(ldconfig -p 2>/dev/null | awk '/libnvidia-opencl.so.1/{print $NF; exit}')
[ -z "$NV" ] && NV=$(find / -xdev -name 'libnvidia-opencl.so.1' 2>/dev/null | head -1)
echo "NVIDIA OpenCL: ${NV:-none}"; ls /etc/OpenCL/vendors 2>/dev/null
LP=$L
if [ -n "$NV" ]; then mkdir -p $K/icd; echo "$NV" > $K/icd/nvidia.icd; export OCL_ICD_VENDORS=$K/icd; LP=$L:$(dirname $NV); fi
R() { $L/ld-linux-x86-64.so.2 --library-path $LP "$@"; }
export SPC_SOURCE_DIR=$PWD
R $K/specula info --devices
RES=${RES:-256}; SPP=${SPP:-256}; SPB=${SPB:-64}; T=${T:-16}
for s in caustic_sdf_torus sdf_shapes_csg; do for i in path bdpt; do
  n=$SPP; [ $i = bdpt ] && n=$SPB
  devs="cpu opencl"; [ $i = bdpt ] && [ -x $K/specula_old ] && devs="$devs old"
  for d in $devs; do
    th=""; [ $d = cpu ] && th="--threads $T --specular-nee none"
    bin=$K/specula; dv=$d; [ $d = old ] && bin=$K/specula_old && dv=opencl
    R $bin render scenes/$s.xml --device $dv $th --integrator $i --max-depth 8 --res ${RES}x${RES} --spp $n --seed 3 --variance --quiet -o $O/${s}_${i}_$d.exr --stats $O/st.json || echo "FAILED $s $i $d"
    python3 -c "import json,sys; j=json.load(open('$O/st.json')); w=j['wall_seconds']; print('$s $i $d spp $n wall %.2f s  samples/s %.3g' % (w, $RES*$RES*$n/w))"
  done
  for d in $devs; do [ $d = cpu ] && continue; echo "cpu vs $d:"
    R $K/specula diff $O/${s}_${i}_cpu.exr $O/${s}_${i}_$d.exr 2>&1 | grep -E "ratio|z-test"; done
done; done
rm -f $O/*.png $O/st.json
ls $O
timeout ${TT:-200} env R=1 $L/ld-linux-x86-64.so.2 --library-path $LP $K/test_opencl 2>&1 | tail -25
