// Binary PPM (P6, 8-bit) into a tfjs int32 tensor [H, W, 3]: the test images of the face-api oracle scripts need no
// image decoder.
import fs from 'fs';

export function readPpm(tf, path) {
  const data = fs.readFileSync(path);
  const fields = [];
  let i = 0;
  while (fields.length < 4) {
    while (data[i] === 0x23 || /\s/.test(String.fromCharCode(data[i]))) {
      if (data[i] === 0x23) while (data[i] !== 0x0a) i++;  // comment
      i++;
    }
    let token = '';
    while (!/\s/.test(String.fromCharCode(data[i]))) token += String.fromCharCode(data[i++]);
    fields.push(token);
  }
  if (fields[0] !== 'P6' || fields[3] !== '255') throw new Error(`${path}: not an 8-bit binary PPM`);
  const [width, height] = [Number(fields[1]), Number(fields[2])];
  const pixels = new Int32Array(data.subarray(i + 1, i + 1 + width * height * 3));
  return tf.tensor3d(pixels, [height, width, 3], 'int32');
}
