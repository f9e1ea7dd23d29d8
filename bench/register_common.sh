# shellcheck shell=bash
# Sourced by bench/register_model.sh, register_texture.sh, register_variants.sh, register_texture_landmarks.sh and
# register_shape_points.sh: the detected-landmark schedule, the per-scan registration, the texture reference and the
# table they share.

# The detected-landmark schedule (scan register's own for detected points: weight 10 -> 0 over the first steps).
# shellcheck disable=SC2034  # used by the scripts that source this one
detected_schedule="--landmark-weight 10 3.33333 1.11111 0 0 0"

# register_into BIN TEMPLATE SCANS OUT [FLAGS...]: `scan register` SCANS into OUT, geometry only (--maps-res 0), niced,
# with $REGISTER_FLAGS last. Scans OUT already holds a report.json for are skipped (scan register resumes), so a row is
# rerun by deleting its folder.
register_into() {
  local bin=$1 template=$2 scans=$3 out=$4
  shift 4
  # shellcheck disable=SC2086  # REGISTER_FLAGS holds several flags
  nice "$bin/bareskin" scan register -q --template "$template" --scans "$scans" -o "$out" --maps-res 0 "$@" \
      ${REGISTER_FLAGS:-}
}

# register_table OUT: runs the Python on stdin with OUT as sys.argv[1] and bench/register_table.py importable.
register_table() {
  PYTHONPATH="$(dirname "${BASH_SOURCE[0]}")${PYTHONPATH:+:$PYTHONPATH}" /usr/bin/python3 - "$1"
}

# texture_reference BIN TEMPLATE DEMO_SCANS OUT: the texture landmarks' reference, the mean of DEMO_SCANS' diffuse maps
# registered from their true landmarks at 512 (OUT/reference_registered, OUT/reference512.png, both cached); prints
# its absolute path.
texture_reference() {
  local bin=$1 template=$2 scans=$3 out=$4
  [ -d "$out/reference_registered" ] || nice "$bin/bareskin" -q scan register --template "$template" \
      --scans "$scans" -o "$out/reference_registered" --maps-res 512 >&2
  [ -f "$out/reference512.png" ] || "$bin/bareskin" -q uvtools mean -o "$out/reference512.png" \
      "$out/reference_registered"/subject_*/diffuse.png >&2
  echo "$(cd "$out" && pwd)/reference512.png"
}
