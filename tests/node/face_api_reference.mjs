// Reference outputs of face-api's own JavaScript (npm @vladmandic/face-api, tfjs CPU backend) for the oracle test
// of 'bareskin landmarks detect' (tests/cli/landmarks.sh).
//   node face_api_reference.mjs ASSETS/face_api IMAGE.ppm INPUT_SIZE MIN_SCORE > reference.json
// IMAGE is a binary PPM (P6, 8-bit), which needs no decoder. For each face: score, box [x, y, w, h], and the 68
// points shifted by the crop's integer origin (where the landmark network looked; face-api itself shifts by the
// unrounded box, also given as points_face_api).
import { importFaceApi, loadWeights } from './face_api.mjs';
import { readPpm } from './ppm.mjs';

const [folder, image, inputSize, minScore] = process.argv.slice(2);
if (!minScore) {
  console.error('usage: node face_api_reference.mjs FACE_API_FOLDER IMAGE.ppm INPUT_SIZE MIN_SCORE');
  process.exit(2);
}
const faceapi = await importFaceApi(folder);
const tf = faceapi.tf;
loadWeights(tf, faceapi.nets.tinyFaceDetector, folder, 'tiny_face_detector_model');
loadWeights(tf, faceapi.nets.faceLandmark68Net, folder, 'face_landmark_68_model');

const img = readPpm(tf, image);
const options = new faceapi.TinyFaceDetectorOptions({ inputSize: Number(inputSize), scoreThreshold: Number(minScore) });
const results = await faceapi.detectAllFaces(img, options).withFaceLandmarks();
const [height, width] = img.shape;
const faces = results.map((r) => {
  const b = r.detection.box;
  const crop = b.clipAtImageBorders(width, height);  // floored, as the crop face-api feeds the landmark network
  return {
    score: r.detection.score,
    box: [b.x, b.y, b.width, b.height],
    points: r.unshiftedLandmarks.positions.map((p) => [p.x + crop.x, p.y + crop.y]),
    points_face_api: r.landmarks.positions.map((p) => [p.x, p.y]),
  };
}).sort((a, b) => b.score - a.score);
console.log(JSON.stringify({ image, width, height, tfjs: tf.version_core, faces }));
