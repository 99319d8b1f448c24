#include "mlmap/core/config.h"
#include "mlmap/core/key_list.h"

#include <gtest/gtest.h>

#include <string>

namespace mlmap {
namespace {

TEST(KeyList, KeyPathNamesAFieldAsItsKeyListDoes) {
  const MapConfig c;
  EXPECT_EQ(keyPath(c, c.awareness.rho_cells), "awareness.rho_cells");
  EXPECT_EQ(keyPath(c, c.local_map.size_cells), "local_map.size_cells");
  EXPECT_EQ(keyPath(c, c.esdf.unknown_as), "esdf.unknown_as");
  EXPECT_EQ(keyPath(c.esdf, c.esdf.box_size_m), "box_size_m");
  // A section and its first key share an address: the type tells them apart.
  EXPECT_EQ(keyPath(c, c.awareness), "awareness");
  EXPECT_EQ(keyPath(c, c.awareness.rho_cell_m), "awareness.rho_cell_m");
  // A field of another struct is no key of this one.
  const MapConfig other;
  EXPECT_EQ(keyPath(c, other.awareness.rho_cells), "");
}

TEST(KeyList, ValidationMessagesNameTheKeysOfTheList) {
  MapConfig c;
  c.awareness.phi_cells = 0;
  c.pipeline.batch_queue_capacity = 0;
  const std::vector<std::string> errors = c.validate();
  ASSERT_EQ(errors.size(), 2U);
  EXPECT_EQ(errors[0].rfind(keyPath(c, c.awareness.phi_cells) + ": ", 0), 0U) << errors[0];
  EXPECT_EQ(errors[1].rfind(keyPath(c, c.pipeline.batch_queue_capacity) + ": ", 0), 0U)
      << errors[1];
}

}  // namespace
}  // namespace mlmap
