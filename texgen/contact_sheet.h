// `texgen show`: a contact sheet of a face shard set, one sample a row: makeup | before | bare | skin | landmarks
// (the 68 landmarks drawn on the makeup image: green visible, red hidden). A member the sample lacks (ingested real
// pairs have no bare.png) is a grey tile marked "n/a".
#pragma once
#include <string>

#include "core/image.h"

namespace bareskin::texgen {

struct ContactSheetOptions {
  int count = 8;   // rows (samples), in shard order
  int tile = 256;  // tile size in pixels (members of another size are resampled)
  void check() const;  // InvalidInput naming the flag
};

// `dataset`: a shard set folder (manifest.json), a single .tar, or a `texgen faces` output whose train/, val/ and test/
// each hold one (read in that order). InvalidInput for anything else or a set without samples. Returns an sRGB image.
Image contact_sheet(const std::string& dataset, const ContactSheetOptions& options);

}  // namespace bareskin::texgen
