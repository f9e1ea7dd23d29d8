#include "core/safetensors.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <nlohmann/json.hpp>

#include "core/files.h"
#include "core/error.h"

namespace bareskin {
namespace {

struct DTypeInfo {
  DType dtype;
  const char* name;
  size_t size;
};
constexpr DTypeInfo kDTypes[] = {
    {DType::BOOL, "BOOL", 1}, {DType::U8, "U8", 1},     {DType::I8, "I8", 1},   {DType::U16, "U16", 2},
    {DType::I16, "I16", 2},   {DType::F16, "F16", 2},   {DType::BF16, "BF16", 2}, {DType::U32, "U32", 4},
    {DType::I32, "I32", 4},   {DType::F32, "F32", 4},   {DType::U64, "U64", 8}, {DType::I64, "I64", 8},
    {DType::F64, "F64", 8},
};
constexpr uint64_t kMaxHeader = 100u << 20;  // as Python's reader

float half_to_float(uint16_t h) {
  const uint32_t sign = uint32_t(h >> 15) << 31, exponent = (h >> 10) & 0x1f, mantissa = h & 0x3ff;
  uint32_t bits;
  if (exponent == 0) {
    if (mantissa == 0) {
      bits = sign;
    } else {  // subnormal: value = mantissa * 2^-24
      const float v = std::ldexp(float(mantissa), -24);
      return sign ? -v : v;
    }
  } else if (exponent == 31) {
    bits = sign | 0x7f800000u | (mantissa << 13);
  } else {
    bits = sign | ((exponent + 112) << 23) | (mantissa << 13);
  }
  float f;
  std::memcpy(&f, &bits, 4);
  return f;
}

template <class T>
T load(const uint8_t* p) {
  T v;
  std::memcpy(&v, p, sizeof(T));  // files are little-endian, as is every machine we build for
  return v;
}

}  // namespace

size_t dtype_size(DType dtype) {
  for (const auto& d : kDTypes) {
    if (d.dtype == dtype) return d.size;
  }
  return 0;
}

const char* dtype_name(DType dtype) {
  for (const auto& d : kDTypes) {
    if (d.dtype == dtype) return d.name;
  }
  return "?";
}

int64_t TensorView::numel() const {
  int64_t n = 1;
  for (int64_t s : shape) n *= s;
  return n;
}

double TensorView::as_double(int64_t i) const {
  const uint8_t* p = data + size_t(i) * dtype_size(dtype);
  switch (dtype) {
    case DType::BOOL: return p[0] != 0;
    case DType::U8: return p[0];
    case DType::I8: return load<int8_t>(p);
    case DType::U16: return load<uint16_t>(p);
    case DType::I16: return load<int16_t>(p);
    case DType::F16: return half_to_float(load<uint16_t>(p));
    case DType::BF16: {
      const uint32_t bits = uint32_t(load<uint16_t>(p)) << 16;
      float f;
      std::memcpy(&f, &bits, 4);
      return f;
    }
    case DType::U32: return load<uint32_t>(p);
    case DType::I32: return load<int32_t>(p);
    case DType::F32: return load<float>(p);
    case DType::U64: return double(load<uint64_t>(p));
    case DType::I64: return double(load<int64_t>(p));
    case DType::F64: return load<double>(p);
  }
  return 0;
}

template <>
DType dtype_of<float>() { return DType::F32; }
template <>
DType dtype_of<double>() { return DType::F64; }
template <>
DType dtype_of<int32_t>() { return DType::I32; }
template <>
DType dtype_of<int64_t>() { return DType::I64; }
template <>
DType dtype_of<uint8_t>() { return DType::U8; }

template <class T>
std::vector<T> TensorView::to_vector() const {
  std::vector<T> out(static_cast<size_t>(numel()));
  if (dtype == dtype_of<T>()) {
    std::memcpy(out.data(), data, nbytes);
  } else if (dtype == DType::I64 && std::is_integral<T>::value) {
    for (size_t i = 0; i < out.size(); ++i) out[i] = T(load<int64_t>(data + 8 * i));
  } else {
    for (size_t i = 0; i < out.size(); ++i) out[i] = T(as_double(int64_t(i)));
  }
  return out;
}
template std::vector<float> TensorView::to_vector<float>() const;
template std::vector<double> TensorView::to_vector<double>() const;
template std::vector<int32_t> TensorView::to_vector<int32_t>() const;
template std::vector<int64_t> TensorView::to_vector<int64_t>() const;
template std::vector<uint8_t> TensorView::to_vector<uint8_t>() const;

SafeTensors SafeTensors::open(const std::string& path) {
  struct stat st {};
  const int fd = ::open(path.c_str(), O_RDONLY);
  if (fd < 0) {
    throw IoError(path, std::string("cannot open: ") + std::strerror(errno),
                  errno == ENOENT ? "check the path" : "check its permissions");
  }
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    throw IoError(path, "is not a regular file", "name a .safetensors file");
  }
  const size_t size = size_t(st.st_size);
  SafeTensors file;
  file.source_ = path;
  if (size < 8) {
    ::close(fd);
    throw InvalidInput(path, "is " + std::to_string(size) + " bytes, too short for a safetensors header",
                       "the file is truncated or not safetensors");
  }
  void* map = ::mmap(nullptr, size, PROT_READ, MAP_PRIVATE, fd, 0);
  ::close(fd);
  if (map == MAP_FAILED) throw IoError(path, std::string("cannot map: ") + std::strerror(errno), "");
  file.storage_ = std::shared_ptr<const void>(map, [size](const void* p) { ::munmap(const_cast<void*>(p), size); });
  file.parse_header(static_cast<const uint8_t*>(map), size);
  return file;
}

SafeTensors SafeTensors::parse(std::string bytes, const std::string& source) {
  SafeTensors file;
  file.source_ = source;
  auto owned = std::make_shared<std::string>(std::move(bytes));
  file.storage_ = std::shared_ptr<const void>(owned, owned->data());
  file.parse_header(reinterpret_cast<const uint8_t*>(owned->data()), owned->size());
  return file;
}

void SafeTensors::parse_header(const uint8_t* bytes, size_t size) {
  const auto bad = [&](const std::string& what) {
    throw InvalidInput(source_, what, "the file is truncated, corrupt or not safetensors");
  };
  if (size < 8) bad("too short for a safetensors header");
  const uint64_t n = load<uint64_t>(bytes);
  if (n > kMaxHeader) bad("header length " + std::to_string(n) + " is implausibly large");
  if (n > size - 8) bad("header length " + std::to_string(n) + " exceeds the file size " + std::to_string(size));
  if (n < 2 || bytes[8] != '{') bad("header does not start with '{'");
  const nlohmann::json header = nlohmann::json::parse(bytes + 8, bytes + 8 + n, nullptr, false);
  if (header.is_discarded() || !header.is_object()) bad("header is not a JSON object");
  const uint8_t* data = bytes + 8 + n;
  const uint64_t data_size = size - 8 - n;

  std::vector<std::pair<uint64_t, uint64_t>> ranges;
  for (const auto& [name, entry] : header.items()) {
    if (name == "__metadata__") {
      if (!entry.is_object()) bad("__metadata__ is not an object");
      for (const auto& [k, v] : entry.items()) {
        if (!v.is_string()) bad("__metadata__ value for '" + k + "' is not a string");
        metadata_[k] = v.get<std::string>();
      }
      continue;
    }
    if (!entry.is_object() || !entry.contains("dtype") || !entry.contains("shape") || !entry.contains("data_offsets") ||
        !entry["dtype"].is_string() || !entry["shape"].is_array() || !entry["data_offsets"].is_array() ||
        entry["data_offsets"].size() != 2) {
      bad("tensor '" + name + "' lacks dtype, shape or data_offsets");
    }
    TensorView view;
    const std::string dtype = entry["dtype"].get<std::string>();
    const auto it = std::find_if(std::begin(kDTypes), std::end(kDTypes), [&](const DTypeInfo& d) { return dtype == d.name; });
    if (it == std::end(kDTypes)) bad("tensor '" + name + "' has unsupported dtype '" + dtype + "'");
    view.dtype = it->dtype;
    uint64_t numel = 1;
    for (const auto& s : entry["shape"]) {
      if (!s.is_number_unsigned()) bad("tensor '" + name + "' has a negative or non-integer extent");
      const uint64_t extent = s.get<uint64_t>();
      if (extent != 0 && numel > (uint64_t(1) << 62) / extent) bad("tensor '" + name + "' shape overflows");
      numel *= extent;
      view.shape.push_back(int64_t(extent));
    }
    const auto& offsets = entry["data_offsets"];
    if (!offsets[0].is_number_unsigned() || !offsets[1].is_number_unsigned()) bad("tensor '" + name + "' has bad offsets");
    const uint64_t begin = offsets[0].get<uint64_t>(), end = offsets[1].get<uint64_t>();
    if (begin > end || end > data_size) {
      bad("tensor '" + name + "' bytes [" + std::to_string(begin) + ", " + std::to_string(end) + ") lie outside the " +
          std::to_string(data_size) + "-byte data section");
    }
    if (end - begin != numel * it->size) bad("tensor '" + name + "' byte count does not match its shape and dtype");
    view.data = data + begin;
    view.nbytes = size_t(end - begin);
    tensors_[name] = view;
    ranges.emplace_back(begin, end);
  }
  // The data section must be covered exactly, without gaps or overlaps (as Python's reader requires).
  std::sort(ranges.begin(), ranges.end());
  uint64_t cursor = 0;
  for (const auto& [b, e] : ranges) {
    if (b != cursor) bad("tensor data has a gap or overlap at byte " + std::to_string(b));
    cursor = e;
  }
  if (cursor != data_size) bad("data section has " + std::to_string(data_size - cursor) + " bytes no tensor claims");
  for (const auto& [name, view] : tensors_) names_.push_back(name);
  std::sort(names_.begin(), names_.end(),
            [&](const std::string& a, const std::string& b) { return tensors_[a].data < tensors_[b].data; });
}

const TensorView& SafeTensors::tensor(const std::string& name) const {
  const auto it = tensors_.find(name);
  if (it == tensors_.end()) throw InvalidInput(source_, "has no tensor '" + name + "'", "is it the right kind of file?");
  return it->second;
}

const TensorView& SafeTensors::tensor(const std::string& name, DType dtype, const std::vector<int64_t>& shape) const {
  const TensorView& view = tensor(name);
  bool ok = view.dtype == dtype && view.shape.size() == shape.size();
  for (size_t i = 0; ok && i < shape.size(); ++i) ok = shape[i] < 0 || shape[i] == view.shape[i];
  if (!ok) {
    const auto str = [](const std::vector<int64_t>& s) {
      std::string r = "[";
      for (size_t i = 0; i < s.size(); ++i) r += (i ? ", " : "") + (s[i] < 0 ? std::string("*") : std::to_string(s[i]));
      return r + "]";
    };
    throw InvalidInput(source_, "tensor '" + name + "' is " + dtype_name(view.dtype) + " " + str(view.shape) +
                                    ", expected " + dtype_name(dtype) + " " + str(shape),
                       "the file was written by another version or tool");
  }
  return view;
}

void SafeTensorsWriter::add(const std::string& name, DType dtype, const std::vector<int64_t>& shape, const void* data,
                            size_t nbytes) {
  if (name.empty() || name == "__metadata__") throw InvalidInput("", "invalid tensor name '" + name + "'", "");
  if (entries_.count(name)) throw InvalidInput("", "tensor '" + name + "' added twice", "");
  int64_t numel = 1;
  for (int64_t s : shape) {
    if (s < 0) throw InvalidInput("", "tensor '" + name + "' has a negative extent", "");
    numel *= s;
  }
  if (size_t(numel) * dtype_size(dtype) != nbytes) {
    throw InvalidInput("", "tensor '" + name + "': " + std::to_string(nbytes) + " bytes do not match its shape", "");
  }
  entries_[name] = Entry{dtype, shape, std::string(static_cast<const char*>(data), nbytes)};
}

template <class T>
void SafeTensorsWriter::add(const std::string& name, const std::vector<int64_t>& shape, const std::vector<T>& values) {
  add(name, dtype_of<T>(), shape, values.data(), values.size() * sizeof(T));
}
template void SafeTensorsWriter::add(const std::string&, const std::vector<int64_t>&, const std::vector<float>&);
template void SafeTensorsWriter::add(const std::string&, const std::vector<int64_t>&, const std::vector<double>&);
template void SafeTensorsWriter::add(const std::string&, const std::vector<int64_t>&, const std::vector<int32_t>&);
template void SafeTensorsWriter::add(const std::string&, const std::vector<int64_t>&, const std::vector<int64_t>&);
template void SafeTensorsWriter::add(const std::string&, const std::vector<int64_t>&, const std::vector<uint8_t>&);

std::string SafeTensorsWriter::serialize() const {
  std::vector<const std::pair<const std::string, Entry>*> order;
  for (const auto& e : entries_) order.push_back(&e);
  std::stable_sort(order.begin(), order.end(), [](auto* a, auto* b) {
    return dtype_size(a->second.dtype) > dtype_size(b->second.dtype);  // names already sorted by the map
  });
  nlohmann::ordered_json header;
  if (!metadata_.empty()) header["__metadata__"] = metadata_;
  uint64_t offset = 0;
  for (const auto* e : order) {
    header[e->first] = {{"dtype", dtype_name(e->second.dtype)},
                        {"shape", e->second.shape},
                        {"data_offsets", {offset, offset + e->second.bytes.size()}}};
    offset += e->second.bytes.size();
  }
  std::string json = header.dump();
  json.append((8 - json.size() % 8) % 8, ' ');  // keeps the data section 8-byte aligned
  std::string out(8, '\0');
  const uint64_t n = json.size();
  std::memcpy(out.data(), &n, 8);
  out += json;
  out.reserve(out.size() + offset);
  for (const auto* e : order) out += e->second.bytes;
  return out;
}

void SafeTensorsWriter::write(const std::string& path) const { write_file_atomic(path, serialize()); }

}  // namespace bareskin
