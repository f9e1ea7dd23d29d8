// The iBUG-68 landmark scheme's left/right symmetry, for test-time mirroring, flip augmentation and sided shapes.
#pragma once
#include <array>

namespace bareskin {

// Point k of a horizontally mirrored face is point kIbug68Mirror[k] of the face: jaw 0..16 reversed, brows 17..26
// reversed, nose bridge 27..30 and tip 33 on the midline, nostrils 31..35 reversed, eyes 36..41 ↔ 42..47 (corners
// 36 ↔ 45, 39 ↔ 42), outer lips 48..59 and inner lips 60..67 about the midline points 51, 57, 62, 66.
inline constexpr std::array<int, 68> kIbug68Mirror = {
    16, 15, 14, 13, 12, 11, 10, 9,  8,  7,  6,  5,  4,  3,  2,  1,  0,  26, 25, 24, 23, 22, 21,
    20, 19, 18, 17, 27, 28, 29, 30, 35, 34, 33, 32, 31, 45, 44, 43, 42, 47, 46, 39, 38, 37, 36,
    41, 40, 54, 53, 52, 51, 50, 49, 48, 59, 58, 57, 56, 55, 64, 63, 62, 61, 60, 67, 66, 65};

}  // namespace bareskin
