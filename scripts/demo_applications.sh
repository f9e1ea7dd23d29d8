# The paper's applications for the demo report, as a function to source (scripts/demo.sh):
#   source scripts/demo_applications.sh
#   demo_applications BIN AVATAR_DIR OUT_DIR
# Writes into OUT_DIR: looks/ (every built-in look on the avatar: an avatar folder, before_after.png and viewer.html
# each, and looks/viewer.html with all of them), relit_{photo,key_left,key_right}.png (relight), light/ (the photo's
# light as light_sh.json + light_env.exr), and, where chromium and node are installed, viewer_{bare,red_lips,key}.png:
# screenshots of the offline viewer. Prints one HTML fragment on stdout for the report (links and images relative to
# OUT_DIR's parent). Returns non-zero when a command fails.
demo_applications() {
  local bin=$1 avatar=$2 out=$3 here
  here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
  mkdir -p "$out" || return 1
  "$bin" makeup apply -q "$avatar" --looks all -o "$out/looks" || return 1
  "$bin" relight -q "$avatar" --size 512 -o "$out/relit_photo.png" --export-light "$out/light" || return 1
  "$bin" relight -q "$avatar" --size 512 --direction 1,0.3,0.6 -o "$out/relit_key_left.png" || return 1
  "$bin" relight -q "$avatar" --size 512 --direction -1,0.3,0.6 -o "$out/relit_key_right.png" || return 1
  local name shots=""
  name=$(basename "$out")
  if command -v chromium > /dev/null && command -v node > /dev/null; then
    mkdir -p "$out/shots"
    node "$here/tests/node/viewer_check.mjs" "$(command -v chromium)" "$out/looks/viewer.html" "$out/shots" \
      "variant=bare&preset=photo" "variant=red_lips&preset=photo" "variant=glam&az=60&el=20" > "$out/shots/report.json" &&
      cp "$out/shots/page_0.png" "$out/viewer_bare.png" && cp "$out/shots/page_1.png" "$out/viewer_red_lips.png" &&
      cp "$out/shots/page_2.png" "$out/viewer_key.png" &&
      shots="<p>The viewer in headless Chromium: <img src=\"$name/viewer_bare.png\" width=256> <img src=\"$name/viewer_red_lips.png\" width=256> <img src=\"$name/viewer_key.png\" width=256></p>"
  fi
  cat <<HTML
<h2>Applications: makeup and relighting</h2>
<p><a href="$name/looks/viewer.html">Open the avatar in the offline viewer</a> (bare, every built-in look, the photo's unwrap; a light to turn).</p>
<p>Before / after, natural and glam, under the three preview lights:<br><img src="$name/looks/natural/before_after.png" width=600><br><img src="$name/looks/glam/before_after.png" width=600></p>
<p>Relit with the four maps: the photo's light, a key light from the left, from the right:<br><img src="$name/relit_photo.png" width=256> <img src="$name/relit_key_left.png" width=256> <img src="$name/relit_key_right.png" width=256></p>
$shots
HTML
}
