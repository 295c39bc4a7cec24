// docs/solver.md's method table is hand-written (its rows say far more than the
// method table's one line): it must list every method of the table, in the
// table's order, and name the option of every pass a method runs behind one.
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "solver/photometric_methods.h"

namespace scanbench {
namespace {

struct DocsRow {
  std::string name;  // the first cell's `name`
  std::string text;  // the whole row
};

// The rows of the first table after the "## Methods" heading.
std::vector<DocsRow> DocsMethodRows(const std::string& path) {
  std::ifstream in(path);
  EXPECT_TRUE(in) << "cannot read " << path;
  std::vector<DocsRow> rows;
  std::string line;
  bool in_section = false, in_table = false;
  int table_line = 0;
  while (std::getline(in, line)) {
    if (line.rfind("## ", 0) == 0) {
      if (in_section) break;
      in_section = line == "## Methods";
      continue;
    }
    if (!in_section) continue;
    if (line.rfind("|", 0) != 0) {
      if (in_table) break;
      continue;
    }
    in_table = true;
    if (++table_line <= 2) continue;  // the header and its rule
    const size_t open = line.find('`'), close = line.find('`', open + 1);
    const size_t first_cell_end = line.find('|', 1);
    EXPECT_TRUE(open != std::string::npos && close != std::string::npos && close < first_cell_end)
        << path << ": a method row without a `name` in its first cell: " << line;
    if (close == std::string::npos) continue;
    rows.push_back({line.substr(open + 1, close - open - 1), line});
  }
  return rows;
}

TEST(SolverMethodsDocsTest, TheDocsTableListsEveryMethodInTheTablesOrder) {
  const std::string path = std::string(SCANBENCH_SOURCE_DIR) + "/docs/solver.md";
  const std::vector<DocsRow> docs = DocsMethodRows(path);
  const auto methods = PhotometricMethods();
  std::vector<std::string> documented, tabled;
  for (const DocsRow& row : docs) documented.push_back(row.name);
  for (const PhotometricMethodRow& row : methods) tabled.push_back(row.name);
  ASSERT_EQ(documented, tabled) << path << "'s \"## Methods\" table and solver/photometric_methods.cc differ";
  for (size_t i = 0; i < methods.size(); ++i) {
    for (const MethodPass& pass : methods[i].passes) {
      if (pass.option_name == nullptr) continue;
      EXPECT_NE(docs[i].text.find(std::string("`") + pass.option_name + "`"), std::string::npos)
          << path << ": the row of " << methods[i].name << " does not name `" << pass.option_name << "`";
    }
  }
}

}  // namespace
}  // namespace scanbench
