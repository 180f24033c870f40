#include "core/internal/rgb_png.h"

#include <gtest/gtest.h>
#include <png.h>

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

}  // namespace
}  // namespace octo_slice_mapper
