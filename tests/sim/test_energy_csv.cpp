// energy.csv (README.md, docs/scene-format.md): a header naming the columns, then one row
// per frame whose values sit under their names.
#include <gtest/gtest.h>

#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "sim/simulation_core.hpp"

using namespace weft;

TEST(EnergyCsv, EachValueSitsUnderItsColumnName) {
  EnergyRow e;
  e.time = 0.25;
  e.kinetic = 1.5;
  e.elastic = 2.25;
  e.gravity = -3.125;
  e.viscous_dissipated = 0.0625;
  e.numerical_dissipated = 0.375;
  e.contact_work = -0.5;
  std::istringstream in(energy_csv({e}));
  std::string header, row, extra;
  ASSERT_TRUE(std::getline(in, header));
  ASSERT_TRUE(std::getline(in, row));
  EXPECT_FALSE(std::getline(in, extra)) << "one row per frame";
  std::vector<std::string> names, values;
  for (std::istringstream h(header); std::getline(h, extra, ',');) names.push_back(extra);
  for (std::istringstream r(row); std::getline(r, extra, ',');) values.push_back(extra);
  ASSERT_EQ(names.size(), values.size());
  const std::map<std::string, double> expected = {{"time", 0.25},           {"kinetic", 1.5},
                                                  {"elastic", 2.25},        {"gravity", -3.125},
                                                  {"viscous_dissipated", 0.0625}, {"numerical_dissipated", 0.375},
                                                  {"contact_work", -0.5},
                                                  {"total", 1.5 + 2.25 - 3.125}};
  ASSERT_EQ(names.size(), expected.size());
  for (size_t k = 0; k < names.size(); ++k) {
    ASSERT_TRUE(expected.count(names[k])) << "unexpected column " << names[k];
    EXPECT_EQ(std::stod(values[k]), expected.at(names[k])) << names[k];
  }
}
