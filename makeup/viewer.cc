#include "makeup/viewer.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>

#include "avatar/glb.h"
#include "core/assets.h"
#include "core/error.h"
#include "core/files.h"
#include "core/image_io.h"
#include "core/parallel.h"
#include "core/png.h"
#include "render/sh.h"

namespace fs = std::filesystem;

namespace bareskin::looks {
namespace {

std::string base64(const std::string& bytes) {
  static const char* k = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const uint32_t v = uint32_t(uint8_t(bytes[i])) << 16 | uint32_t(uint8_t(bytes[i + 1])) << 8 | uint8_t(bytes[i + 2]);
    for (int s : {18, 12, 6, 0}) out += k[(v >> s) & 63];
  }
  if (i + 1 == bytes.size()) {
    const uint32_t v = uint32_t(uint8_t(bytes[i])) << 16;
    out += k[(v >> 18) & 63], out += k[(v >> 12) & 63], out += "==";
  } else if (i + 2 == bytes.size()) {
    const uint32_t v = uint32_t(uint8_t(bytes[i])) << 16 | uint32_t(uint8_t(bytes[i + 1])) << 8;
    out += k[(v >> 18) & 63], out += k[(v >> 12) & 63], out += k[(v >> 6) & 63], out += '=';
  }
  return out;
}

std::string js_uri(const std::string& source) { return "data:text/javascript;base64," + base64(source); }
Image srgb(const Image& m) { return m.color_space == ColorSpace::Linear ? to_srgb(m) : m; }

// The photo light as the page's key + ambient: the SH light's strongest direction and intensity (dominant_light) and
// what is left of its band 0 (a key light of intensity I adds I / 4 to it).
nlohmann::json photo_preset(const ShLight& g) {
  const KeyLight key = dominant_light(g);
  const double k0 = sh_scales().k0;
  Eigen::Vector3d ambient;
  for (int c = 0; c < 3; ++c) ambient[c] = std::max(0.0, g[size_t(9 * c)] * k0 - key.intensity[c] / 4);
  const Eigen::Vector3d d = key.direction.norm() > 0 ? key.direction : Eigen::Vector3d(0, 0, 1);
  return {{"az", std::atan2(d.x(), d.z()) * 180 / M_PI},
          {"el", std::asin(std::clamp(d.y(), -1.0, 1.0)) * 180 / M_PI},
          {"key", {key.intensity[0], key.intensity[1], key.intensity[2]}},
          {"ambient", {ambient[0], ambient[1], ambient[2]}}};
}

std::string replace_all(std::string s, const std::string& from, const std::string& to) {
  for (size_t at = 0; (at = s.find(from, at)) != std::string::npos; at += to.size()) s.replace(at, from.size(), to);
  return s;
}

const char* const kPage = R"HTML(<!doctype html>
<html><head><meta charset="utf-8"><title>BareSkin avatar</title>
<style>
body{margin:0;background:#202020;color:#ddd;font:13px sans-serif;overflow:hidden}
#ui{position:absolute;left:8px;top:8px;background:rgba(0,0,0,.55);padding:8px 10px;border-radius:4px}
#ui label{display:block;margin:3px 0} #ui input{vertical-align:middle}
#status{position:absolute;right:8px;bottom:4px;margin:0;color:#999}
</style>
<script>
window.__errors = [];
function __report(text) {
  window.__errors.push(text);
  const s = document.getElementById('status');
  if (s) s.textContent = 'error: ' + window.__errors.join(' | ');
}
window.addEventListener('error', e => __report(String(e.message)));
window.addEventListener('unhandledrejection', e => __report(String(e.reason && e.reason.message || e.reason)));
const __consoleError = console.error;
console.error = (...a) => { __report(a.map(String).join(' ')); __consoleError(...a); };
</script>
<script type="importmap">@IMPORTMAP@</script>
</head><body>
<canvas id="view"></canvas>
<div id="ui">
<label>maps <select id="variant"></select></label>
<label>light azimuth <input id="az" type="range" min="-180" max="180" step="1" value="30"></label>
<label>light elevation <input id="el" type="range" min="-89" max="89" step="1" value="25"></label>
<label>key intensity <input id="i" type="range" min="0" max="3" step="0.05" value="1"></label>
<label>ambient <input id="amb" type="range" min="0" max="1.5" step="0.05" value="0.35"></label>
<button id="photo">photo light</button> <button id="white">white light</button>
<div style="color:#999">drag to turn the head</div>
</div>
<pre id="status">loading</pre><pre id="capture" hidden></pre>
<script type="application/json" id="data">@DATA@</script>
<script type="module">
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
const data = JSON.parse(document.getElementById('data').textContent);
const $ = id => document.getElementById(id);
const renderer = new THREE.WebGLRenderer({ canvas: $('view'), antialias: true, preserveDrawingBuffer: true });
renderer.setPixelRatio(1);
renderer.setSize(innerWidth, innerHeight);
const scene = new THREE.Scene();
scene.background = new THREE.Color(0x202020);
const camera = new THREE.PerspectiveCamera(20, innerWidth / innerHeight, 0.01, 10);
const key = new THREE.DirectionalLight(0xffffff, Math.PI);
const ambient = new THREE.AmbientLight(0xffffff, 0.35 * Math.PI);
scene.add(key, key.target, ambient);
const bytes = s => Uint8Array.from(atob(s), c => c.charCodeAt(0)).buffer;
const gltf = await new GLTFLoader().parseAsync(bytes(data.glb), '');
const head = new THREE.Group();
head.add(gltf.scene);
scene.add(head);
let material = null;
gltf.scene.traverse(o => { if (o.isMesh) material = o.material; });
const box = new THREE.Box3().setFromObject(gltf.scene);
gltf.scene.position.sub(box.getCenter(new THREE.Vector3()));
const radius = box.getSize(new THREE.Vector3()).length() / 2;
camera.position.set(0, 0, 1.1 * radius / Math.tan(10 * Math.PI / 180));
camera.lookAt(0, 0, 0);
const bare = { map: material.map, roughnessMap: material.roughnessMap, specularIntensityMap: material.specularIntensityMap };
const loader = new THREE.TextureLoader();
const texture = (uri, colour) => uri ? loader.loadAsync(uri).then(t => {
  t.flipY = false;  // glTF's UV origin, as the GLB's own textures
  t.colorSpace = colour ? THREE.SRGBColorSpace : THREE.NoColorSpace;
  return t;
}) : Promise.resolve(null);
const cache = {};
async function show(name) {
  const v = data.variants.find(v => v.name === name) || data.variants[0];
  if (!cache[v.name]) cache[v.name] = v.diffuse === undefined ? Promise.resolve(bare) :
    Promise.all([texture(v.diffuse, true), texture(v.roughness, false), texture(v.specular, false)]).then(([d, r, s]) =>
      ({ map: d, roughnessMap: r || bare.roughnessMap, specularIntensityMap: s || bare.specularIntensityMap }));
  Object.assign(material, await cache[v.name]);
  material.needsUpdate = true;
  $('variant').value = v.name;
}
function light() {
  const az = +$('az').value * Math.PI / 180, el = +$('el').value * Math.PI / 180;
  key.position.set(Math.sin(az) * Math.cos(el), Math.sin(el), Math.cos(az) * Math.cos(el)).multiplyScalar(2);
  key.intensity = +$('i').value * Math.PI;
  ambient.intensity = +$('amb').value * Math.PI;
}
function render() { light(); renderer.render(scene, camera); }
function preset(p) {
  const peak = Math.max(...p.key, 1e-6), amb = Math.max(...p.ambient, 1e-6);
  $('az').value = p.az; $('el').value = p.el; $('i').value = peak; $('amb').value = amb;
  key.color.setRGB(...p.key.map(v => v / peak));
  ambient.color.setRGB(...p.ambient.map(v => v / amb));
}
const white = () => { key.color.setRGB(1, 1, 1); ambient.color.setRGB(1, 1, 1); };
for (const v of data.variants) $('variant').add(new Option(v.name, v.name));
$('photo').disabled = !data.photo;
$('photo').onclick = () => { preset(data.photo); render(); };
$('white').onclick = () => { white(); render(); };
for (const id of ['az', 'el', 'i', 'amb']) $(id).oninput = render;
$('variant').onchange = async () => { await show($('variant').value); render(); };
let drag = null;
$('view').onpointerdown = e => { drag = [e.clientX, e.clientY]; };
onpointerup = () => { drag = null; };
onpointermove = e => {
  if (!drag) return;
  head.rotation.y += (e.clientX - drag[0]) * 0.01;
  head.rotation.x = Math.max(-1.2, Math.min(1.2, head.rotation.x + (e.clientY - drag[1]) * 0.01));
  drag = [e.clientX, e.clientY];
  render();
};
onresize = () => { renderer.setSize(innerWidth, innerHeight); camera.aspect = innerWidth / innerHeight; camera.updateProjectionMatrix(); render(); };
// State from the URL: #variant=NAME&az=..&el=..&i=..&amb=..&preset=photo&yaw=..
const hash = new URLSearchParams(location.hash.slice(1));
if (hash.get('preset') === 'photo' && data.photo) preset(data.photo);
for (const id of ['az', 'el', 'i', 'amb']) if (hash.has(id)) $(id).value = hash.get(id);
if (hash.has('yaw')) head.rotation.y = +hash.get('yaw') * Math.PI / 180;
await show(hash.get('variant') || data.variants[0].name);
render();
if (!window.__errors.length) $('status').textContent = 'ready';
// #capture: the canvas as a PNG data URL in #capture, for headless browsers' --dump-dom (the browser test).
if (hash.has('capture')) $('capture').textContent = renderer.domElement.toDataURL('image/png');
</script>
</body></html>
)HTML";

}  // namespace

std::string viewer_html(const ViewerInputs& in) {
  BS_CHECK(in.avatar && !in.variants.empty(), "a viewer needs an avatar and a variant");
  const std::string dir = find_data_dir(DataKind::Assets, "", "three/three.module.min.js") + "/three";
  const std::string three = read_file(dir + "/three.module.min.js");
  // The loader's one relative import becomes a bare name the import map resolves (a data: URL has no base).
  const std::string loader = replace_all(read_file(dir + "/GLTFLoader.js"), "'../utils/BufferGeometryUtils.js'",
                                         "'three/addons/utils/BufferGeometryUtils.js'");
  const nlohmann::json importmap = {{"imports",
                                     {{"three", js_uri(three)},
                                      {"three/addons/loaders/GLTFLoader.js", js_uri(loader)},
                                      {"three/addons/utils/BufferGeometryUtils.js",
                                       js_uri(read_file(dir + "/BufferGeometryUtils.js"))}}}};
  // Every PNG of the page encoded once, in parallel: the GLB's four (the bare 1× maps), then each variant's (its
  // diffuse, roughness and specular texture, or a diffuse alone), unless the variant brings them encoded.
  const avatar_folder::MapSet& m = in.avatar->maps;
  std::vector<std::function<std::string()>> jobs = {
      [&] { return encode_png(to_srgb(m.diffuse), 8); }, [&] { return encode_png(m.normal, 8); },
      [&] { return encode_png(m.roughness, 8); }, [&] { return encode_png(texture::specular_texture(m.specular), 8); }};
  std::vector<std::vector<std::pair<std::string, size_t>>> variant_pngs;  // per variant: key -> job index
  for (const ViewerVariant& v : in.variants) {
    auto& keys = variant_pngs.emplace_back();
    const auto add = [&](const char* key, const std::string& given, std::function<std::string()> job) {
      keys.push_back({key, jobs.size()});
      jobs.push_back(given.empty() ? std::move(job) : [&given] { return given; });
    };
    if (v.maps && v.maps != &in.avatar->maps) {
      add("diffuse", v.diffuse_png, [&v] { return encode_png(srgb(v.maps->diffuse), 8); });
      add("roughness", v.roughness_png, [&v] { return encode_png(v.maps->roughness, 8); });
      add("specular", "", [&v] { return encode_png(texture::specular_texture(v.maps->specular), 8); });
    } else if (v.diffuse_only) {
      add("diffuse", "", [&v] { return encode_png(srgb(*v.diffuse_only), 8); });
    }
  }
  std::vector<std::string> png(jobs.size());
  parallel_for(0, int64_t(jobs.size()), [&](int64_t b, int64_t e) {
    for (int64_t i = b; i < e; ++i) png[size_t(i)] = jobs[size_t(i)]();
  });
  const std::string glb = texture::glb_bytes(in.avatar->mesh, texture::PbrPngs{png[0], png[1], png[2], png[3]});
  nlohmann::json data = {{"glb", base64(glb)}, {"variants", nlohmann::json::array()}};
  for (size_t i = 0; i < in.variants.size(); ++i) {
    nlohmann::json j = {{"name", in.variants[i].name}};
    for (const auto& [key, job] : variant_pngs[i]) j[key] = "data:image/png;base64," + base64(png[job]);
    data["variants"].push_back(j);
  }
  if (in.photo_light) data["photo"] = photo_preset(*in.photo_light);
  std::string page = kPage;
  page = replace_all(page, "@IMPORTMAP@", importmap.dump());
  return replace_all(page, "@DATA@", replace_all(data.dump(), "<", "\\u003c"));
}

ViewerInputs folder_viewer(const avatar_folder::Folder& bare, const std::vector<avatar_folder::Folder>& looks,
                           std::vector<std::string>& names, Image& unwrap) {
  ViewerInputs in;
  in.avatar = &bare;
  names.clear();
  for (const auto& l : looks) {
    const auto j = nlohmann::json::parse(read_file(l.dir + "/look.json"), nullptr, false);
    names.push_back(!j.is_discarded() && j.contains("name") && j["name"].is_string() ? j["name"].get<std::string>()
                                                                                       : fs::path(l.dir).filename().string());
  }
  in.variants.push_back({"bare", &bare.maps, nullptr});
  for (size_t i = 0; i < looks.size(); ++i) in.variants.push_back({names[i], &looks[i].maps, nullptr});
  if (fs::exists(bare.dir + "/unwrap.png")) {
    unwrap = read_image(bare.dir + "/unwrap.png", ColorSpace::sRGB);
    in.variants.push_back({"photo unwrap", nullptr, &unwrap});
  }
  try {
    in.photo_light = avatar_folder::photo_light(bare.dir);
  } catch (const InvalidInput&) {
  }
  return in;
}

void viewer_command(const std::string& avatar, const std::vector<std::string>& look_dirs, const std::string& output) {
  const avatar_folder::Folder bare = avatar_folder::read(avatar);
  std::vector<avatar_folder::Folder> looks;
  for (const auto& d : look_dirs) {
    if (!fs::exists(d + "/look.json"))
      throw InvalidInput(d, "is not a folder written by makeup apply (no look.json)", "give makeup apply's output");
    looks.push_back(avatar_folder::read(d));
  }
  std::vector<std::string> names;
  Image unwrap;
  const ViewerInputs in = folder_viewer(bare, looks, names, unwrap);
  write_file_atomic(output.empty() ? avatar + "/viewer.html" : output, viewer_html(in));
}

}  // namespace bareskin::looks
