// Reference descriptors of face-api's own JavaScript (npm @vladmandic/face-api, tfjs CPU backend) for the oracle test
// of detect/face_recognition (detect/face_recognition_test.cc).
//   node face_recognition_reference.mjs ASSETS/face_api IMAGE.ppm... > reference.json
// Prints {"tfjs": version, "descriptors": [[128 numbers] per image]}: FaceRecognitionNet.computeFaceDescriptor of
// each whole image (face-api pads it to a centred square and resizes it to 150² itself).
import fs from 'fs';
import { readPpm } from './ppm.mjs';

const [folder, ...images] = process.argv.slice(2);
if (images.length === 0) {
  console.error('usage: node face_recognition_reference.mjs FACE_API_FOLDER IMAGE.ppm...');
  process.exit(2);
}
// The bundle's node platform needs require('util'), which an ES module lacks; its browser platform works in node.
globalThis.window = globalThis;
globalThis.document = {};
const faceapi = await import(`${folder}/dist/face-api.esm.js`);
const tf = faceapi.tf;
await tf.setBackend('cpu');
await tf.ready();

const manifest = JSON.parse(fs.readFileSync(`${folder}/face_recognition_model-weights_manifest.json`));
const bin = fs.readFileSync(`${folder}/${manifest[0].paths[0]}`);
const buffer = bin.buffer.slice(bin.byteOffset, bin.byteOffset + bin.length);
faceapi.nets.faceRecognitionNet.loadFromWeightMap(tf.io.decodeWeights(buffer, manifest[0].weights));

const descriptors = [];
for (const image of images) {
  const img = readPpm(tf, image);
  descriptors.push(Array.from(await faceapi.nets.faceRecognitionNet.computeFaceDescriptor(img)));
  img.dispose();
}
console.log(JSON.stringify({ tfjs: tf.version_core, descriptors }));
