// SPDX-License-Identifier: BSD-3-Clause
#include "adit/map/content_hash.hpp"

#include <openssl/evp.h>

#include <cstdio>
#include <cstring>
#include <memory>

#include "adit/map/map_io.hpp"

namespace adit::map {

std::uint64_t fnv1a64(const void* data, std::size_t size, std::uint64_t h) {
  const auto* p = static_cast<const unsigned char*>(data);
  for (std::size_t i = 0; i < size; ++i) h = (h ^ p[i]) * 0x100000001b3ull;  // FNV-1a 64 prime
  return h;
}

namespace {
constexpr std::uint64_t kPrime1 = 0x9E3779B185EBCA87ull, kPrime2 = 0xC2B2AE3D27D4EB4Full;
inline std::uint64_t rotl(std::uint64_t x, int r) { return (x << r) | (x >> (64 - r)); }
inline std::uint64_t lane(std::uint64_t acc, std::uint64_t w) { return rotl(acc + w * kPrime2, 31) * kPrime1; }
inline std::uint64_t load64(const unsigned char* p) {
  std::uint64_t w;
  std::memcpy(&w, p, 8);
  return w;
}
}  // namespace

std::uint64_t checksum64(const void* data, std::size_t size) {
  const auto* p = static_cast<const unsigned char*>(data);
  // Four lanes keep four multiplies in flight; one lane would wait on each multiply's latency.
  std::uint64_t a = kPrime1 + kPrime2, b = kPrime2, c = 0, d = 0 - kPrime1;
  std::size_t i = 0;
  for (; i + 32 <= size; i += 32) {
    a = lane(a, load64(p + i));
    b = lane(b, load64(p + i + 8));
    c = lane(c, load64(p + i + 16));
    d = lane(d, load64(p + i + 24));
  }
  std::uint64_t h = rotl(a, 1) + rotl(b, 7) + rotl(c, 12) + rotl(d, 18) + std::uint64_t(size);
  // The tail byte by byte, then a final avalanche so that every input bit reaches every output bit.
  for (; i < size; ++i) h = (h ^ p[i]) * 0x100000001b3ull;
  h ^= h >> 33;
  h *= kPrime2;
  h ^= h >> 29;
  return h;
}

std::string contentHash(std::string_view bytes) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "fnv1a64:%016llx", static_cast<unsigned long long>(fnv1a64(bytes)));
  return buf;
}

StatusOr<std::string> fileContentHash(const std::string& path) {
  ADIT_ASSIGN_OR_RETURN(const std::string bytes, readFile(path));
  return contentHash(bytes);
}

std::string sha256Hex(std::string_view bytes) {
  unsigned char md[EVP_MAX_MD_SIZE];
  unsigned int len = 0;
  // EVP_Digest is OpenSSL 3's one-shot digest; it fails only when the library cannot allocate,
  // and then no digest is a match for anything (empty string).
  if (EVP_Digest(bytes.data(), bytes.size(), md, &len, EVP_sha256(), nullptr) != 1) return std::string();
  static const char* const hex = "0123456789abcdef";
  std::string out(2 * len, '0');
  for (unsigned int i = 0; i < len; ++i) {
    out[2 * i] = hex[md[i] >> 4];
    out[2 * i + 1] = hex[md[i] & 0xf];
  }
  return out;
}

}  // namespace adit::map
