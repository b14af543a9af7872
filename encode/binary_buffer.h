// Appending plain values to a byte buffer, in host byte order (the binary writers are
// little-endian-only and check for it).
#pragma once

#include <vector>

namespace isoslab {

template <typename T>
void appendBytes(std::vector<char>& buffer, const T& value) {
  const auto* p = reinterpret_cast<const char*>(&value);
  buffer.insert(buffer.end(), p, p + sizeof(T));
}

}  // namespace isoslab
