// Reference descriptors of face-api's own JavaScript (npm @vladmandic/face-api, tfjs CPU backend) for the oracle test
// of detect/face_recognition (detect/face_recognition_test.cc).
//   node face_recognition_reference.mjs ASSETS/face_api IMAGE.ppm... > reference.json
// Prints {"tfjs": version, "descriptors": [[128 numbers] per image]}: FaceRecognitionNet.computeFaceDescriptor of
// each whole image (face-api pads it to a centred square and resizes it to 150² itself).
import { importFaceApi, loadWeights } from './face_api.mjs';
import { readPpm } from './ppm.mjs';

const [folder, ...images] = process.argv.slice(2);
if (images.length === 0) {
  console.error('usage: node face_recognition_reference.mjs FACE_API_FOLDER IMAGE.ppm...');
  process.exit(2);
}
const faceapi = await importFaceApi(folder);
const tf = faceapi.tf;

loadWeights(tf, faceapi.nets.faceRecognitionNet, folder, 'face_recognition_model');

const descriptors = [];
for (const image of images) {
  const img = readPpm(tf, image);
  descriptors.push(Array.from(await faceapi.nets.faceRecognitionNet.computeFaceDescriptor(img)));
  img.dispose();
}
console.log(JSON.stringify({ tfjs: tf.version_core, descriptors }));
