// SPDX-License-Identifier: BSD-3-Clause
#include "adit/map/content_hash.hpp"

#include <openssl/evp.h>

#include <cstdio>
#include <memory>

#include "adit/map/map_io.hpp"

namespace adit::map {

std::uint64_t fnv1a64(const void* data, std::size_t size, std::uint64_t h) {
  const auto* p = static_cast<const unsigned char*>(data);
  for (std::size_t i = 0; i < size; ++i) h = (h ^ p[i]) * 0x100000001b3ull;  // FNV-1a 64 prime
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
