// The safetensors format (models, datasets, checkpoints): 8-byte little-endian header length N, N bytes of JSON
// {"name": {"dtype": "F32", "shape": [..], "data_offsets": [begin, end]}, ..., "__metadata__": {"k": "v"}},
// then the raw little-endian tensor bytes. Files we write are read by Python's `safetensors` unchanged.
#pragma once
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace bareskin {

enum class DType { BOOL, U8, I8, U16, I16, F16, BF16, U32, I32, F32, U64, I64, F64 };
size_t dtype_size(DType dtype);
const char* dtype_name(DType dtype);  // "F32", ...

struct TensorView {
  DType dtype = DType::F32;
  std::vector<int64_t> shape;
  const uint8_t* data = nullptr;  // not necessarily aligned
  size_t nbytes = 0;

  int64_t numel() const;
  // Element i converted to double / int64 (F16 and BF16 decoded).
  double as_double(int64_t i) const;
  // All elements converted to T (float, double, int32_t, int64_t, uint8_t).
  template <class T>
  std::vector<T> to_vector() const;
};

// A parsed safetensors file. `open` memory-maps the file; views stay valid while the object lives.
class SafeTensors {
 public:
  // IoError when missing/unreadable; InvalidInput (naming the file) when the header or offsets are malformed.
  static SafeTensors open(const std::string& path);
  // Parses bytes already in memory (tests, fuzzing). `source` names them in errors.
  static SafeTensors parse(std::string bytes, const std::string& source);

  const std::map<std::string, std::string>& metadata() const { return metadata_; }
  const std::vector<std::string>& names() const { return names_; }  // in data order
  bool contains(const std::string& name) const { return tensors_.count(name) != 0; }
  // InvalidInput naming the file when absent.
  const TensorView& tensor(const std::string& name) const;
  // tensor(name) checked for a dtype and shape (-1 matches any extent); InvalidInput when it differs.
  const TensorView& tensor(const std::string& name, DType dtype, const std::vector<int64_t>& shape) const;
  const std::string& source() const { return source_; }

 private:
  void parse_header(const uint8_t* bytes, size_t size);
  std::shared_ptr<const void> storage_;
  std::string source_;
  std::map<std::string, std::string> metadata_;
  std::map<std::string, TensorView> tensors_;
  std::vector<std::string> names_;
};

class SafeTensorsWriter {
 public:
  // Copies the bytes. InvalidInput when nbytes does not match the shape or the name is taken.
  void add(const std::string& name, DType dtype, const std::vector<int64_t>& shape, const void* data, size_t nbytes);
  template <class T>
  void add(const std::string& name, const std::vector<int64_t>& shape, const std::vector<T>& values);
  void set_metadata(const std::string& key, const std::string& value) { metadata_[key] = value; }
  // Tensors are laid out largest dtype first (then by name), so every tensor is aligned to its element size.
  std::string serialize() const;
  void write(const std::string& path) const;  // atomic

 private:
  struct Entry {
    DType dtype;
    std::vector<int64_t> shape;
    std::string bytes;
  };
  std::map<std::string, Entry> entries_;
  std::map<std::string, std::string> metadata_;
};

// Maps a C++ element type to its dtype (float→F32, double→F64, int32_t→I32, int64_t→I64, uint8_t→U8).
template <class T>
DType dtype_of();

}  // namespace bareskin
