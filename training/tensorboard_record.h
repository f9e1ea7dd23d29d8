// TFRecord framing, the container of TensorBoard event files: each record is
//   uint64 length (little endian) | uint32 masked CRC32C of those 8 bytes | data | uint32 masked CRC32C of the data
// CRC32C is the Castagnoli CRC (reflected polynomial 0x82F63B78, as in iSCSI and ext4); "masked" rotates it right by 15
// bits and adds 0xa282ead8, so that a CRC over bytes that themselves hold CRCs stays well distributed.
#pragma once
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

namespace bareskin {

uint32_t crc32c(std::string_view bytes);
uint32_t masked_crc32c(std::string_view bytes);
// One whole record around `data` (data.size() + 16 bytes).
std::string tfrecord(std::string_view data);

}  // namespace bareskin
