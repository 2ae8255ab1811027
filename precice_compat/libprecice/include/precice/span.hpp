#pragma once
// A view of contiguous elements (pointer and count), as preCICE v3's API takes its arrays and names
// (precice::span, precice::string_view). C++11: an adapter may build with any standard from 11 on. Its template
// signature and layout are std::span's (element type and extent; pointer, then count), so that the API's symbols are
// those an adapter built against preCICE calls.

#include <array>
#include <cstddef>
#include <cstring>
#include <type_traits>
#include <vector>

namespace precice {

constexpr std::size_t dynamic_extent = static_cast<std::size_t>(-1);

namespace detail {
// the count of a C array: a char array is a string, up to its first NUL (a literal's terminator is not in it)
template <typename T, std::size_t N>
std::size_t array_count(T (&)[N], std::false_type) noexcept { return N; }
template <typename T, std::size_t N>
std::size_t array_count(T (&array)[N], std::true_type) noexcept
{
  std::size_t count = 0;
  while (count < N && array[count] != '\0') ++count;
  return count;
}
template <typename T>
struct is_char : std::integral_constant<bool, std::is_same<typename std::remove_cv<T>::type, char>::value> {};
} // namespace detail

template <typename T, std::size_t Extent = dynamic_extent>
class span {
public:
  using element_type    = T;
  using value_type      = typename std::remove_cv<T>::type;
  using size_type       = std::size_t;
  using difference_type = std::ptrdiff_t;
  using pointer         = T *;
  using reference       = T &;
  using iterator        = T *;

  span() noexcept : data_(nullptr), size_(0) {}
  span(pointer data, size_type size) noexcept : data_(data), size_(size) {}
  span(pointer first, pointer last) noexcept : data_(first), size_(static_cast<size_type>(last - first)) {}

  template <std::size_t N>
  span(element_type (&array)[N]) noexcept : data_(array), size_(detail::array_count(array, detail::is_char<T>())) {}

  // a C string (a pointer, not an array): its characters up to the NUL
  template <typename P, typename std::enable_if<std::is_pointer<P>::value &&
                                                    detail::is_char<typename std::remove_pointer<P>::type>::value &&
                                                    std::is_convertible<P, pointer>::value,
                                                int>::type = 0>
  span(const P &text) noexcept : data_(text), size_(text ? std::strlen(text) : 0) {}

  // any container that holds its elements contiguously: std::vector, std::array, std::string, std::string_view
  template <typename Container,
            typename Pointer = decltype(std::declval<Container &>().data()),
            typename std::enable_if<!std::is_array<typename std::remove_reference<Container>::type>::value &&
                                        !std::is_pointer<typename std::remove_reference<Container>::type>::value &&
                                        std::is_convertible<Pointer, pointer>::value,
                                    int>::type = 0>
  span(Container &&container) noexcept : data_(container.data()), size_(container.size()) {}

  // span<const T> from span<T>
  template <typename U, std::size_t N, typename std::enable_if<std::is_convertible<U (*)[], T (*)[]>::value, int>::type = 0>
  span(const span<U, N> &other) noexcept : data_(other.data()), size_(other.size()) {}

  pointer   data() const noexcept { return data_; }
  size_type size() const noexcept { return size_; }
  size_type size_bytes() const noexcept { return size_ * sizeof(T); }
  bool      empty() const noexcept { return size_ == 0; }
  reference operator[](size_type i) const noexcept { return data_[i]; }
  reference front() const noexcept { return data_[0]; }
  reference back() const noexcept { return data_[size_ - 1]; }
  iterator  begin() const noexcept { return data_; }
  iterator  end() const noexcept { return data_ + size_; }
  static constexpr std::size_t extent = Extent;

  span      subspan(size_type offset, size_type count) const noexcept { return span(data_ + offset, count); }
  span      first(size_type count) const noexcept { return span(data_, count); }
  span      last(size_type count) const noexcept { return span(data_ + size_ - count, count); }

private:
  pointer   data_;
  size_type size_;
};

} // namespace precice
