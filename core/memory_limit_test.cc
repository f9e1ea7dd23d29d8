// The memory limit: sizes parsed, and headers that promise more than the limit refused before anything is allocated
// (a handmade PNG through core's decoder and through OpenImageIO), and PNG chunks longer than their file.
#include "core/memory_limit.h"

#include <gtest/gtest.h>
#include <zlib.h>

#include <cstdlib>
#include <functional>
#include <string>

#include "core/error.h"
#include "core/files.h"
#include "core/image_io.h"
#include "core/png.h"
#include "core/test_util.h"

namespace bareskin {
namespace {

std::string be32(uint32_t v) {
  return {char(v >> 24), char(v >> 16), char(v >> 8), char(v)};
}

std::string chunk(const std::string& type, const std::string& data) {
  const std::string body = type + data;
  return be32(uint32_t(data.size())) + body +
         be32(uint32_t(crc32(0, reinterpret_cast<const Bytef*>(body.data()), uInt(body.size()))));
}

// A PNG whose header claims width x height RGB 8-bit pixels, followed by a few bytes of image data and IEND.
std::string lying_png(uint32_t width, uint32_t height) {
  const std::string ihdr = be32(width) + be32(height) + std::string{8, 2, 0, 0, 0};
  const std::string idat = {0x78, 0x01, 0x01, 0x00, 0x00, char(0xff), char(0xff), 0, 0, 0, 1};
  return std::string("\x89PNG\r\n\x1a\n", 8) + chunk("IHDR", ihdr) + chunk("IDAT", idat) + chunk("IEND", "");
}

std::string message(const std::function<void()>& f) {
  try {
    f();
  } catch (const InvalidInput& e) {
    return e.what();
  }
  return "";
}

TEST(MemoryLimit, SizesParse) {
  EXPECT_EQ(parse_memory_size("8G", "x"), int64_t(8000000000));
  EXPECT_EQ(parse_memory_size("512m", "x"), int64_t(512000000));
  EXPECT_EQ(parse_memory_size("1500000", "x"), 1500000);
  EXPECT_EQ(parse_memory_size("2T", "x"), int64_t(2000000000000));
  for (const char* bad : {"", "G", "-1", "0", "1.5G", "8X", "8GB", "99999999999999999999"})
    EXPECT_THROW(parse_memory_size(bad, "x"), InvalidInput) << bad;
  EXPECT_EQ(max_memory(), kDefaultMaxMemory);
}

TEST(MemoryLimit, PngHeaderPromisingTooMuchIsRefusedBeforeDecoding) {
  // 200,000 x 200,000 RGB: 120 GB of 8-bit samples, 480 GB as floats; the default limit (8 GB) refuses it.
  const std::string m = message([] { decode_png(lying_png(200000, 200000), "huge.png"); });
  EXPECT_EQ(m.rfind("huge.png: ", 0), 0u) << m;
  EXPECT_NE(m.find("200000x200000 PNG"), std::string::npos) << m;
  EXPECT_NE(m.find("memory limit of 8 GB"), std::string::npos) << m;
  EXPECT_EQ(m.find('\n'), std::string::npos) << "one line: " << m;
  // The same file through OpenImageIO (read_image), with a limit set as the flag sets it.
  const std::string path = testing::temp_dir() + "/huge.png";
  write_file_atomic(path, lying_png(20000, 20000));  // 4.8 GB of float pixels
  set_max_memory("1G");
  const std::string m2 = message([&] { read_image(path); });
  set_max_memory("8G");
  EXPECT_NE(m2.find("20000x20000 png image needs 4.8 GB, more than the memory limit of 1 GB"), std::string::npos) << m2;
  // Below the limit the header is not refused: the missing pixels are the error.
  const std::string m3 = message([] { decode_png(lying_png(64, 64), "short.png"); });
  EXPECT_NE(m3.find("corrupt PNG"), std::string::npos) << m3;
}

TEST(MemoryLimit, PngChunkLongerThanTheFileIsRefusedBeforeLibpngAllocatesIt) {
  // A tEXt chunk whose length (2 GB) runs past the end of the file: in the middle, and as a bare 8-byte header at the
  // very end (no data, no CRC), which libpng would allocate before finding the data missing.
  const std::string head =
      std::string("\x89PNG\r\n\x1a\n", 8) + chunk("IHDR", be32(16) + be32(16) + std::string{8, 0, 0, 0, 0});
  for (const std::string& png : {head + be32(0x7ffffff0) + "tEXtabcdefgh" + chunk("IEND", ""),
                                 head + be32(0x7ffffff0) + "tEXt", head + be32(0x7ffffff0) + "tEXtab"}) {
    const std::string m = message([&] { decode_png(png, "text.png"); });
    EXPECT_NE(m.find("text.png: corrupt PNG (chunk 'tEXt' of 2147483632 bytes runs past the end of the file)"),
              std::string::npos)
        << m;
    // The same file through OpenImageIO, whose libpng took 2.2 GB and 16 s on it.
    const std::string path = testing::temp_dir() + "/text.png";
    write_file_atomic(path, png);
    const std::string m2 = message([&] { read_image(path); });
    EXPECT_NE(m2.find(path + ": corrupt PNG (chunk 'tEXt' of 2147483632 bytes runs past the end of the file)"),
              std::string::npos)
        << m2;
  }
}

}  // namespace
}  // namespace bareskin
