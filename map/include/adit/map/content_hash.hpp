// SPDX-License-Identifier: BSD-3-Clause
#pragma once
/// @file
/// Content identity, written once for every layer. A map's identity is FNV-1a 64 of its file's
/// bytes, spelled "fnv1a64:<16 hex digits>": a campaign shard records it, a robot's hello sends
/// it and the console compares it with the map it serves, so all three must compute the same
/// string. FNV-1a is a fingerprint against accidents (another file, an edited map), not a
/// defence against someone who forges content on purpose; where a file's bytes must be checkable
/// by anyone with standard tools (a campaign shard's rows), sha256Hex() gives the digest that
/// `sha256sum` prints.
///
///   StatusOr<std::string> id = fileContentHash("maps/district.yaml");  // "fnv1a64:…"
///   std::string d = sha256Hex(csv_text);                                 // 64 hex digits

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "adit/status.hpp"

namespace adit::map {

inline constexpr std::uint64_t kFnv1a64Basis = 0xcbf29ce484222325ull;

/// FNV-1a 64 of `size` bytes at `data`, continuing from `h` (the basis to start afresh): feeding
/// a sequence in pieces gives the hash of the whole.
std::uint64_t fnv1a64(const void* data, std::size_t size, std::uint64_t h = kFnv1a64Basis);
inline std::uint64_t fnv1a64(std::string_view bytes, std::uint64_t h = kFnv1a64Basis) {
  return fnv1a64(bytes.data(), bytes.size(), h);
}

/// A fast 64-bit checksum (four independent multiply-rotate lanes over 8-byte words, about ten
/// times FNV-1a's byte loop): the map cache's sections are hundreds of megabytes and are checked
/// on every load. Against accidents (a torn or flipped file), like FNV-1a; not a digest.
std::uint64_t checksum64(const void* data, std::size_t size);

/// "fnv1a64:%016llx" of `bytes`.
std::string contentHash(std::string_view bytes);

/// contentHash() of the file's bytes. Errors: the file cannot be read (naming it).
StatusOr<std::string> fileContentHash(const std::string& path);

/// SHA-256 of `bytes` as 64 lowercase hex digits (OpenSSL's implementation).
std::string sha256Hex(std::string_view bytes);

}  // namespace adit::map
