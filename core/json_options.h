// The one way an options struct goes to and from JSON. Each struct lists its keys once, as a generic function over a
// visitor and the struct, and has `void check() const` (InvalidInput for a bad value, naming the key):
//
//   const auto kFields = [](auto& v, auto& o) {
//     v("arch", o.arch);
//     v("width", o.width);
//     v.unless_default("lr_decay", o.lr_decay);  // written only when it differs from the struct's default
//     v.unwritten("face_api", o.face_api);       // read, never written (a machine's path, not part of a run)
//   };
//   void to_json(nlohmann::json& j, const X& o) { json_options::write(j, o, kFields); }
//   void from_json(const nlohmann::json& j, X& o) { json_options::read(j, o, "x", kFields); }
//
// read() refuses a value that is not an object, an unknown key (one line naming it and every known key) and a value
// of the wrong type (naming the key), leaves the keys `j` lacks as they are in `o` (the struct's defaults, or a
// caller's preset: defaults are written once, in the struct), then calls o.check(); `o` is unchanged when it throws.
// Values keep their JSON types: integers are written as integers, and an integer field refuses 1.5.
#pragma once
#include <nlohmann/json.hpp>

#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "core/error.h"

namespace bareskin::json_options {

// InvalidInput("<what> options: unknown key 'k'; known keys: a, b, ...") unless `j` is an object whose keys are all in
// `known`.
void check_keys(const nlohmann::json& j, const std::string& what, const std::vector<std::string>& known);

// Writes every field (unless_default ones only where they differ from a default-constructed struct's).
class Writer {
 public:
  explicit Writer(nlohmann::json& j) : j_(j) {}
  template <typename T>
  void operator()(const char* key, const T& value) {
    j_[key] = value;
  }
  template <typename T>
  void unless_default(const char* key, const T& value) {
    j_[key] = value;
    sparse_.push_back(key);
  }
  template <typename T>
  void unwritten(const char*, const T&) {}
  const std::vector<std::string>& sparse() const { return sparse_; }

 private:
  nlohmann::json& j_;
  std::vector<std::string> sparse_;
};

// The keys of a struct, written or not.
class KeyLister {
 public:
  template <typename T>
  void operator()(const char* key, const T&) {
    keys.emplace_back(key);
  }
  template <typename T>
  void unless_default(const char* key, const T& value) {
    (*this)(key, value);
  }
  template <typename T>
  void unwritten(const char* key, const T& value) {
    (*this)(key, value);
  }
  std::vector<std::string> keys;
};

// Reads the keys present, each with its field's JSON type.
class Reader {
 public:
  Reader(const nlohmann::json& j, std::string what) : j_(j), what_(std::move(what)) {}
  template <typename T>
  void operator()(const char* key, T& value) {
    const auto it = j_.find(key);
    if (it == j_.end()) return;
    const char* kind = nullptr;
    bool ok = true;
    if constexpr (std::is_same_v<T, bool>) {
      kind = "true or false", ok = it->is_boolean();
    } else if constexpr (std::is_integral_v<T>) {
      kind = "an integer", ok = it->is_number_integer();
    } else if constexpr (std::is_floating_point_v<T>) {
      kind = "a number", ok = it->is_number();
    } else if constexpr (std::is_same_v<T, std::string>) {
      kind = "a string", ok = it->is_string();
    }
    try {
      if (ok) it->get_to(value);
    } catch (const nlohmann::json::exception&) {
      ok = false;
    }
    if (!ok) wrong_type(key, *it, kind ? kind : "a value of the default's type", nlohmann::json(value).dump());
  }
  template <typename T>
  void unless_default(const char* key, T& value) {
    (*this)(key, value);
  }
  template <typename T>
  void unwritten(const char* key, T& value) {
    (*this)(key, value);
  }

 private:
  // InvalidInput("<what> options: 'key' has the wrong type (value); give <kind> (default: <default>)").
  [[noreturn]] void wrong_type(const char* key, const nlohmann::json& value, const char* kind,
                               const std::string& default_value) const;
  const nlohmann::json& j_;
  std::string what_;
};

template <typename T, typename Fields>
void write(nlohmann::json& j, const T& o, const Fields& fields) {
  nlohmann::json out = nlohmann::json::object();
  Writer w(out);
  fields(w, o);
  if (!w.sparse().empty()) {
    const T defaults{};
    nlohmann::json d = nlohmann::json::object();
    Writer dw(d);
    fields(dw, defaults);
    for (const std::string& key : w.sparse())
      if (out.at(key) == d.at(key)) out.erase(key);
  }
  j = std::move(out);
}

template <typename T, typename Fields>
void read(const nlohmann::json& j, T& o, const std::string& what, const Fields& fields) {
  KeyLister keys;
  fields(keys, o);
  check_keys(j, what, keys.keys);
  T read = o;
  Reader r(j, what);
  fields(r, read);
  read.check();
  o = std::move(read);
}

}  // namespace bareskin::json_options
