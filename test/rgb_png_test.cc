#include "core/internal/rgb_png.h"

#include <gtest/gtest.h>
#include <png.h>
#include <zlib.h>

#include <cstring>
#include <random>
#include <vector>

namespace octo_slice_mapper {
namespace {

struct Decoded {
  int width = 0, height = 0, colour_type = -1, bit_depth = 0;
  std::vector<std::uint8_t> rgb;  // row by row, top first
};

struct Reader {
  const std::string* bytes;
  std::size_t at = 0;
};

void readFromString(png_structp png, png_bytep out, png_size_t length) {
  auto* r = static_cast<Reader*>(png_get_io_ptr(png));
  if (r->at + length > r->bytes->size()) png_error(png, "past the end");
  std::memcpy(out, r->bytes->data() + r->at, length);
  r->at += length;
}

// The picture as libpng reads it back.
bool decode(const std::string& bytes, Decoded* out) {
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!png || !info) return false;
  Reader reader{&bytes};
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_read_struct(&png, &info, nullptr);
    return false;
  }
  png_set_read_fn(png, &reader, readFromString);
  png_read_info(png, info);
  out->width = static_cast<int>(png_get_image_width(png, info));
  out->height = static_cast<int>(png_get_image_height(png, info));
  out->colour_type = png_get_color_type(png, info);
  out->bit_depth = png_get_bit_depth(png, info);
  out->rgb.assign(std::size_t(out->width) * out->height * 3, 0);
  for (int y = 0; y < out->height; ++y) png_read_row(png, &out->rgb[std::size_t(y) * out->width * 3], nullptr);
  png_read_end(png, nullptr);
  png_destroy_read_struct(&png, &info, nullptr);
  return true;
}

// The filter type byte that starts each row of the image data (the IDAT chunks inflated).
std::vector<int> rowFilters(const std::string& bytes, int width, int height) {
  std::string compressed;
  for (std::size_t at = 8; at + 12 <= bytes.size();) {
    const auto* p = reinterpret_cast<const unsigned char*>(bytes.data() + at);
    const std::size_t length = std::size_t(p[0]) << 24 | std::size_t(p[1]) << 16 | std::size_t(p[2]) << 8 | p[3];
    if (bytes.compare(at + 4, 4, "IDAT") == 0) compressed += bytes.substr(at + 8, length);
    at += 12 + length;
  }
  const std::size_t stride = std::size_t(width) * 3 + 1;
  std::vector<unsigned char> raw(stride * height);
  uLongf raw_size = raw.size();
  if (uncompress(raw.data(), &raw_size, reinterpret_cast<const Bytef*>(compressed.data()), compressed.size()) != Z_OK ||
      raw_size != raw.size()) {
    return {};
  }
  std::vector<int> filters;
  for (int y = 0; y < height; ++y) filters.push_back(raw[std::size_t(y) * stride]);
  return filters;
}

std::string encoded(int width, int height, const std::vector<std::uint8_t>& rgb) {
  std::string bytes, error;
  EXPECT_TRUE(encodeRgbPng(
      width, height,
      [&](int y, std::uint8_t* row) { std::memcpy(row, &rgb[std::size_t(y) * width * 3], std::size_t(width) * 3); },
      &bytes, &error))
      << error;
  return bytes;
}

TEST(RgbPngTest, ReadsBackPixelForPixel) {
  std::mt19937 rng(7);
  // A map-like picture (cells drawn over 4 x 4 pixels, three colours) and noise.
  const int width = 96, height = 40;
  std::vector<std::uint8_t> map(std::size_t(width) * height * 3), noise(map.size());
  const std::uint8_t colours[3][3] = {{196, 204, 216}, {255, 255, 255}, {0, 0, 0}};
  std::vector<int> cells(std::size_t(width / 4) * (height / 4));
  for (int& c : cells) c = int(rng() % 3);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      std::memcpy(&map[(std::size_t(y) * width + x) * 3], colours[cells[std::size_t(y / 4) * (width / 4) + x / 4]], 3);
    }
  }
  for (auto& b : noise) b = static_cast<std::uint8_t>(rng());
  for (const auto* picture : {&map, &noise}) {
    Decoded back;
    ASSERT_TRUE(decode(encoded(width, height, *picture), &back));
    EXPECT_EQ(back.width, width);
    EXPECT_EQ(back.height, height);
    EXPECT_EQ(back.colour_type, PNG_COLOR_TYPE_RGB);
    EXPECT_EQ(back.bit_depth, 8);
    EXPECT_EQ(back.rgb, *picture);
  }
}

TEST(RgbPngTest, OnePixelPicture) {
  const std::vector<std::uint8_t> pixel = {12, 34, 56};
  Decoded back;
  ASSERT_TRUE(decode(encoded(1, 1, pixel), &back));
  EXPECT_EQ(back.rgb, pixel);
}

// Each row is filtered against the one above: a map's repeated rows filter to zeros.
TEST(RgbPngTest, EveryRowIsFilteredAgainstTheOneAbove) {
  const int width = 20, height = 12;
  std::vector<std::uint8_t> rgb(std::size_t(width) * height * 3);
  for (std::size_t k = 0; k < rgb.size(); ++k) rgb[k] = static_cast<std::uint8_t>(k * 37 % 251);
  const std::vector<int> filters = rowFilters(encoded(width, height, rgb), width, height);
  ASSERT_EQ(filters.size(), std::size_t(height));
  for (int y = 0; y < height; ++y) EXPECT_EQ(filters[std::size_t(y)], 2) << "row " << y << " (2: up)";
}

}  // namespace
}  // namespace octo_slice_mapper
