#pragma once
// cosim's wire (version 1): a msgpack header, then one raw frame per array (C order, little-endian float64 or int64),
// each array named and shaped in the header's "arrays" list. The same messages as the Python participant's
// (precice_compat/participant/precice/_wire.py).

#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace cosim {

// A msgpack value as the wire's headers use them: nil, bool, integer, float, string, array, map with string keys.
struct Value {
  enum Kind { Nil, Bool, Int, Float, Str, List, Map };
  Kind                                       kind = Nil;
  bool                                       flag = false;
  std::int64_t                               integer = 0;
  double                                     real = 0.0;
  std::string                                text;
  std::vector<Value>                         items;
  std::vector<std::pair<std::string, Value>> entries;

  static Value map() { Value v; v.kind = Map; return v; }
  static Value list() { Value v; v.kind = List; return v; }
  static Value of(bool b) { Value v; v.kind = Bool; v.flag = b; return v; }
  static Value of(int i) { Value v; v.kind = Int; v.integer = i; return v; }
  static Value of(long i) { Value v; v.kind = Int; v.integer = i; return v; }
  static Value of(long long i) { Value v; v.kind = Int; v.integer = i; return v; }
  static Value of(double d) { Value v; v.kind = Float; v.real = d; return v; }
  static Value of(const std::string &s) { Value v; v.kind = Str; v.text = s; return v; }
  static Value of(const char *s) { return of(std::string(s)); }

  Value &set(const std::string &key, Value value);       // a map's entry, replaced or added
  Value &push(Value value);                               // a list's next item
  const Value *get(const std::string &key) const;        // a map's entry, or null
  bool         truthy() const;                            // Python's truth of the value
  double       number(double otherwise = 0.0) const;     // an int or float as double
  std::int64_t whole(std::int64_t otherwise = 0) const;  // an int (or an integral float)
  std::string  string(const std::string &otherwise = "") const;
  // the map's entry `key` as each of the above (otherwise where it is missing)
  bool         flag_of(const std::string &key, bool otherwise = false) const;
  double       number_of(const std::string &key, double otherwise = 0.0) const;
  std::int64_t whole_of(const std::string &key, std::int64_t otherwise = 0) const;
  std::string  string_of(const std::string &key, const std::string &otherwise = "") const;
};

// An array of a message: its dtype ("float64" or "int64"), shape and bytes.
struct Array {
  std::string              dtype;
  std::vector<std::size_t> shape;
  std::string              bytes;

  std::size_t         count() const;                     // the number of elements
  std::vector<double> doubles() const;                  // float64 elements (an int64 array converted)
};

// An array to send: float64 or int64, given as a pointer to its elements (they must live until the send).
struct OutArray {
  std::string              name;
  std::string              dtype;
  std::vector<std::size_t> shape;
  const void              *data;
  std::size_t              bytes;

  static OutArray of(const std::string &name, const std::vector<double> &values, std::vector<std::size_t> shape);
  static OutArray of(const std::string &name, const std::vector<std::int64_t> &values,
                     std::vector<std::size_t> shape);
};

// The frames of a message: the header (with "v" and "arrays" added) and each array's bytes.
std::vector<std::string> encode(Value header, const std::vector<OutArray> &arrays);

// The header and named arrays of a message's frames; throws std::runtime_error on a message that is not cosim's.
std::pair<Value, std::map<std::string, Array>> decode(const std::vector<std::string> &frames);

} // namespace cosim
