// SPDX-License-Identifier: BSD-3-Clause
// The one content identity every layer uses (map/content_hash.hpp): FNV-1a 64 and SHA-256
// against their published test vectors, pieces hash as the whole, files as their bytes.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "adit/map/content_hash.hpp"

namespace adit::map {
namespace {

TEST(ContentHash, Fnv1a64MatchesTheReferenceVectors) {
  // From the FNV reference (Fowler, Noll, Vo): the empty string is the offset basis.
  EXPECT_EQ(fnv1a64(std::string_view()), 0xcbf29ce484222325ull);
  EXPECT_EQ(fnv1a64("a"), 0xaf63dc4c8601ec8cull);
  EXPECT_EQ(fnv1a64("foobar"), 0x85944171f73967e8ull);
  EXPECT_EQ(contentHash("foobar"), "fnv1a64:85944171f73967e8");
}

TEST(ContentHash, PiecesHashAsTheWhole) {
  const std::string whole = "roadway 3, crosscut 90";
  EXPECT_EQ(fnv1a64(whole.substr(9), fnv1a64(whole.substr(0, 9))), fnv1a64(whole));
}

TEST(ContentHash, Sha256MatchesFips180Vectors) {
  EXPECT_EQ(sha256Hex(""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  EXPECT_EQ(sha256Hex("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ(sha256Hex("abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq"),
            "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
}

TEST(ContentHash, AFileHashesAsItsBytesAndAMissingFileIsNamed) {
  const std::string path =
      (std::filesystem::temp_directory_path() / ("adit_content_hash_" + std::to_string(::getpid()) + ".bin")).string();
  const std::string bytes("map\0with a NUL\n", 15);
  { std::ofstream(path, std::ios::binary) << bytes; }
  const StatusOr<std::string> h = fileContentHash(path);
  std::filesystem::remove(path);
  ASSERT_TRUE(h.ok()) << h.status().message();
  EXPECT_EQ(*h, contentHash(bytes));
  const StatusOr<std::string> missing = fileContentHash("/nonexistent/map.yaml");
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.status().message().find("/nonexistent/map.yaml"), std::string::npos);
}

}  // namespace
}  // namespace adit::map
