#include "core/image.h"

#include <cstdint>

#include <gtest/gtest.h>

namespace scanbench {
namespace {

TEST(ImageReshapeTest, KeepsTheBufferAndItsValuesWhenTheShapeIsTheSame) {
  ImageF image(4, 3, 2, 7.5f);
  const float* buffer = image.data();
  image.Reshape(4, 3, 2);
  EXPECT_EQ(image.data(), buffer);
  EXPECT_EQ(image(3, 2, 1), 7.5f);
}

TEST(ImageReshapeTest, MakesTheImageAnewForAnotherShape) {
  ImageF image(4, 3, 2, 7.5f);
  image.Reshape(5, 3, 2);
  EXPECT_EQ(image.width(), 5);
  EXPECT_EQ(image.height(), 3);
  EXPECT_EQ(image.channels(), 2);
  EXPECT_EQ(image.size(), 30u);
  for (size_t i = 0; i < image.size(); ++i) EXPECT_EQ(image.data()[i], 0.0f) << i;
  // The same pixels in another number of channels is another shape too.
  image.Reshape(5, 3, 1);
  EXPECT_EQ(image.channels(), 1);
  EXPECT_EQ(image.size(), 15u);
}

TEST(ImageReshapeTest, WithAFillSetsEveryValueEitherWay) {
  ImageU8 image(2, 2, 1, uint8_t{9});
  const uint8_t* buffer = image.data();
  image.Reshape(2, 2, 1, uint8_t{3});
  EXPECT_EQ(image.data(), buffer);
  for (size_t i = 0; i < image.size(); ++i) EXPECT_EQ(image.data()[i], 3) << i;
  image.Reshape(3, 1, 2, uint8_t{4});
  EXPECT_EQ(image.width(), 3);
  EXPECT_EQ(image.height(), 1);
  EXPECT_EQ(image.size(), 6u);
  for (size_t i = 0; i < image.size(); ++i) EXPECT_EQ(image.data()[i], 4) << i;
}

TEST(ImageReshapeTest, RefusesANegativeSizeAsTheConstructorDoes) {
  ImageF image;
  EXPECT_THROW(image.Reshape(-1, 2, 1), std::invalid_argument);
}

}  // namespace
}  // namespace scanbench
