#include "wire.hpp"

#include <msgpack.h>

#include <cmath>
#include <cstring>
#include <stdexcept>

namespace cosim {

namespace {

const int VERSION = 1;

void pack_string(msgpack_packer *packer, const std::string &text)
{
  msgpack_pack_str(packer, text.size());
  msgpack_pack_str_body(packer, text.data(), text.size());
}

void pack(msgpack_packer *packer, const Value &value)
{
  switch (value.kind) {
  case Value::Nil: msgpack_pack_nil(packer); break;
  case Value::Bool: value.flag ? msgpack_pack_true(packer) : msgpack_pack_false(packer); break;
  case Value::Int: msgpack_pack_int64(packer, value.integer); break;
  case Value::Float: msgpack_pack_double(packer, value.real); break;
  case Value::Str: pack_string(packer, value.text); break;
  case Value::List:
    msgpack_pack_array(packer, value.items.size());
    for (const Value &item : value.items) pack(packer, item);
    break;
  case Value::Map:
    msgpack_pack_map(packer, value.entries.size());
    for (const auto &entry : value.entries) {
      pack_string(packer, entry.first);
      pack(packer, entry.second);
    }
    break;
  }
}

Value unpack(const msgpack_object &object, int depth)
{
  if (depth > 64) throw std::runtime_error("a message nested too deep");
  Value value;
  switch (object.type) {
  case MSGPACK_OBJECT_NIL: break;
  case MSGPACK_OBJECT_BOOLEAN: value = Value::of(static_cast<bool>(object.via.boolean)); break;
  case MSGPACK_OBJECT_POSITIVE_INTEGER:
    value.kind    = Value::Int;
    value.integer = static_cast<std::int64_t>(object.via.u64);
    break;
  case MSGPACK_OBJECT_NEGATIVE_INTEGER:
    value.kind    = Value::Int;
    value.integer = object.via.i64;
    break;
  case MSGPACK_OBJECT_FLOAT32:
  case MSGPACK_OBJECT_FLOAT64: value = Value::of(object.via.f64); break;
  case MSGPACK_OBJECT_STR: value = Value::of(std::string(object.via.str.ptr, object.via.str.size)); break;
  case MSGPACK_OBJECT_BIN: value = Value::of(std::string(object.via.bin.ptr, object.via.bin.size)); break;
  case MSGPACK_OBJECT_ARRAY:
    value.kind = Value::List;
    for (std::uint32_t i = 0; i < object.via.array.size; ++i) value.items.push_back(unpack(object.via.array.ptr[i], depth + 1));
    break;
  case MSGPACK_OBJECT_MAP:
    value.kind = Value::Map;
    for (std::uint32_t i = 0; i < object.via.map.size; ++i) {
      const msgpack_object_kv &kv = object.via.map.ptr[i];
      if (kv.key.type != MSGPACK_OBJECT_STR) continue;
      value.entries.emplace_back(std::string(kv.key.via.str.ptr, kv.key.via.str.size), unpack(kv.val, depth + 1));
    }
    break;
  default: break;
  }
  return value;
}

std::size_t itemsize(const std::string &dtype)
{
  if (dtype == "float64" || dtype == "int64") return 8;
  if (dtype == "int32") return 4;
  return 0;
}

} // namespace

Value &Value::set(const std::string &key, Value value)
{
  for (auto &entry : entries)
    if (entry.first == key) return entry.second = std::move(value);
  entries.emplace_back(key, std::move(value));
  return entries.back().second;
}

Value &Value::push(Value value)
{
  items.push_back(std::move(value));
  return items.back();
}

const Value *Value::get(const std::string &key) const
{
  if (kind != Map) return nullptr;
  for (const auto &entry : entries)
    if (entry.first == key) return &entry.second;
  return nullptr;
}

bool Value::truthy() const
{
  switch (kind) {
  case Nil: return false;
  case Bool: return flag;
  case Int: return integer != 0;
  case Float: return real != 0.0;
  case Str: return !text.empty();
  case List: return !items.empty();
  case Map: return !entries.empty();
  }
  return false;
}

double Value::number(double otherwise) const
{
  if (kind == Float) return real;
  if (kind == Int) return static_cast<double>(integer);
  return otherwise;
}

std::int64_t Value::whole(std::int64_t otherwise) const
{
  if (kind == Int) return integer;
  if (kind == Float && std::isfinite(real) && std::floor(real) == real) return static_cast<std::int64_t>(real);
  return otherwise;
}

std::string Value::string(const std::string &otherwise) const { return kind == Str ? text : otherwise; }

bool Value::flag_of(const std::string &key, bool otherwise) const
{
  const Value *found = get(key);
  return found ? found->truthy() : otherwise;
}

double Value::number_of(const std::string &key, double otherwise) const
{
  const Value *found = get(key);
  return found ? found->number(otherwise) : otherwise;
}

std::int64_t Value::whole_of(const std::string &key, std::int64_t otherwise) const
{
  const Value *found = get(key);
  return found ? found->whole(otherwise) : otherwise;
}

std::string Value::string_of(const std::string &key, const std::string &otherwise) const
{
  const Value *found = get(key);
  return found ? found->string(otherwise) : otherwise;
}

std::size_t Array::count() const
{
  std::size_t n = 1;
  for (std::size_t extent : shape) n *= extent;
  return n;
}

std::vector<double> Array::doubles() const
{
  std::vector<double> values(count());
  if (dtype == "float64") {
    if (!values.empty()) std::memcpy(values.data(), bytes.data(), values.size() * sizeof(double));
  } else if (dtype == "int64") {
    for (std::size_t i = 0; i < values.size(); ++i) {
      std::int64_t v;
      std::memcpy(&v, bytes.data() + 8 * i, 8);
      values[i] = static_cast<double>(v);
    }
  } else if (dtype == "int32") {
    for (std::size_t i = 0; i < values.size(); ++i) {
      std::int32_t v;
      std::memcpy(&v, bytes.data() + 4 * i, 4);
      values[i] = static_cast<double>(v);
    }
  }
  return values;
}

OutArray OutArray::of(const std::string &name, const std::vector<double> &values, std::vector<std::size_t> shape)
{
  return OutArray{name, "float64", std::move(shape), values.data(), values.size() * sizeof(double)};
}

OutArray OutArray::of(const std::string &name, const std::vector<std::int64_t> &values,
                      std::vector<std::size_t> shape)
{
  return OutArray{name, "int64", std::move(shape), values.data(), values.size() * sizeof(std::int64_t)};
}

std::vector<std::string> encode(Value header, const std::vector<OutArray> &arrays)
{
  Value specs = Value::list();
  for (const OutArray &array : arrays) {
    Value spec  = Value::map();
    spec.set("name", Value::of(array.name));
    spec.set("dtype", Value::of(array.dtype));
    Value shape = Value::list();
    for (std::size_t extent : array.shape) shape.push(Value::of(static_cast<long long>(extent)));
    spec.set("shape", shape);
    specs.push(spec);
  }
  header.set("v", Value::of(VERSION));
  header.set("arrays", specs);
  msgpack_sbuffer buffer;
  msgpack_sbuffer_init(&buffer);
  msgpack_packer packer;
  msgpack_packer_init(&packer, &buffer, msgpack_sbuffer_write);
  pack(&packer, header);
  std::vector<std::string> frames;
  frames.emplace_back(buffer.data, buffer.size);
  msgpack_sbuffer_destroy(&buffer);
  for (const OutArray &array : arrays) frames.emplace_back(static_cast<const char *>(array.data), array.bytes);
  return frames;
}

std::pair<Value, std::map<std::string, Array>> decode(const std::vector<std::string> &frames)
{
  if (frames.empty()) throw std::runtime_error("an empty message");
  msgpack_unpacked unpacked;
  msgpack_unpacked_init(&unpacked);
  std::size_t offset = 0;
  if (msgpack_unpack_next(&unpacked, frames[0].data(), frames[0].size(), &offset) != MSGPACK_UNPACK_SUCCESS) {
    msgpack_unpacked_destroy(&unpacked);
    throw std::runtime_error("a message whose header is not msgpack");
  }
  Value header;
  try {
    header = unpack(unpacked.data, 0);
  } catch (...) {
    msgpack_unpacked_destroy(&unpacked);
    throw;
  }
  msgpack_unpacked_destroy(&unpacked);
  if (header.kind != Value::Map || header.whole_of("v", -1) != VERSION)
    throw std::runtime_error("a message that is not cosim's (wire version " + std::to_string(header.whole_of("v", -1)) + ")");
  std::map<std::string, Array> arrays;
  const Value *specs = header.get("arrays");
  std::size_t  declared = specs && specs->kind == Value::List ? specs->items.size() : 0;
  if (declared != frames.size() - 1)
    throw std::runtime_error("a message declaring " + std::to_string(declared) + " arrays with " +
                             std::to_string(frames.size() - 1) + " frames");
  for (std::size_t i = 0; i < declared; ++i) {
    const Value &spec = specs->items[i];
    Array        array;
    array.dtype = spec.string_of("dtype");
    const Value *shape = spec.get("shape");
    if (shape && shape->kind == Value::List)
      for (const Value &extent : shape->items) array.shape.push_back(static_cast<std::size_t>(extent.whole(0)));
    std::size_t size = itemsize(array.dtype);
    if (size == 0 || array.count() * size != frames[i + 1].size())
      throw std::runtime_error("array '" + spec.string_of("name") + "' does not match its frame");
    array.bytes                          = frames[i + 1];
    arrays[spec.string_of("name")] = std::move(array);
  }
  return {std::move(header), std::move(arrays)};
}

} // namespace cosim
