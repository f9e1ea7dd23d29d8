// face-api's own JavaScript bundle in node (tfjs CPU backend) with a network's weights loaded from the npm package's
// files, for the oracle scripts (face_api_reference.mjs, face_recognition_reference.mjs).
import fs from 'fs';

// The bundle's node platform needs require('util'), which an ES module lacks; its browser platform works in node.
export async function importFaceApi(folder) {
  globalThis.window = globalThis;
  globalThis.document = {};
  const faceapi = await import(`${folder}/dist/face-api.esm.js`);
  await faceapi.tf.setBackend('cpu');
  await faceapi.tf.ready();
  return faceapi;
}

// Loads `<name>-weights_manifest.json` and its single shard from `folder` into `net` (e.g. faceapi.nets.tinyFaceDetector).
export function loadWeights(tf, net, folder, name) {
  const manifest = JSON.parse(fs.readFileSync(`${folder}/${name}-weights_manifest.json`));
  const bin = fs.readFileSync(`${folder}/${manifest[0].paths[0]}`);
  const buffer = bin.buffer.slice(bin.byteOffset, bin.byteOffset + bin.length);
  net.loadFromWeightMap(tf.io.decodeWeights(buffer, manifest[0].weights));
}
