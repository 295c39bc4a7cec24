#include "app/cli/option_fields.h"

#include <algorithm>
#include <cctype>

namespace scanbench {
namespace {

struct OptionField {
  const CLI::Option* option;
  std::string where;  // "SimulatedRigOptions"
  std::string field;  // "width"
};

std::vector<OptionField>& Registry() {
  static std::vector<OptionField> registry;
  return registry;
}

const CLI::App*& Root() {
  static const CLI::App* root = nullptr;
  return root;
}

// The option of `commands` that sets where.field, or nullptr.
const CLI::Option* OptionSetting(const std::vector<const CLI::Option*>& options, const std::string& where,
                                 const std::string& field) {
  for (const OptionField& entry : Registry()) {
    if (entry.where == where && entry.field == field &&
        std::find(options.begin(), options.end(), entry.option) != options.end()) {
      return entry.option;
    }
  }
  return nullptr;
}

bool IsWordCharacter(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; }

// `rule` with every whole-word field of `where` that an option sets named by that option.
std::string NameFieldsInRule(std::string rule, const std::vector<const CLI::Option*>& options,
                             const std::string& where) {
  for (const OptionField& entry : Registry()) {
    if (entry.where != where || std::find(options.begin(), options.end(), entry.option) == options.end()) continue;
    const std::string name = entry.option->get_name();
    for (size_t at = rule.find(entry.field); at != std::string::npos; at = rule.find(entry.field, at)) {
      const size_t end = at + entry.field.size();
      if ((at > 0 && IsWordCharacter(rule[at - 1])) || (end < rule.size() && IsWordCharacter(rule[end]))) {
        at = end;
        continue;
      }
      rule.replace(at, entry.field.size(), name);
      at += name.size();
    }
  }
  return rule;
}

}  // namespace

CLI::Option* SetsField(CLI::Option* option, const std::string& field) {
  const size_t dot = field.find('.');
  Registry().push_back({option, field.substr(0, dot), dot == std::string::npos ? "" : field.substr(dot + 1)});
  return option;
}

CLI::Option* SetsField(CLI::Option* option, std::initializer_list<std::string> fields) {
  for (const std::string& field : fields) SetsField(option, field);
  return option;
}

void SetCommandLineRoot(const CLI::App* root) { Root() = root; }

std::vector<const CLI::Option*> OptionsOf(const std::vector<const CLI::App*>& commands) {
  std::vector<const CLI::Option*> options;
  std::vector<const CLI::App*> pending(commands.begin(), commands.end());
  while (!pending.empty()) {
    const CLI::App* app = pending.back();
    pending.pop_back();
    for (const CLI::Option* option : app->get_options()) options.push_back(option);
    for (const CLI::App* group : app->get_subcommands([](const CLI::App* sub) { return sub->get_name().empty(); })) {
      pending.push_back(group);
    }
  }
  return options;
}

std::vector<const CLI::App*> ParsedCommands(const CLI::App* root) {
  std::vector<const CLI::App*> chain;
  for (const CLI::App* app = root; app != nullptr;) {
    chain.push_back(app);
    const CLI::App* next = nullptr;
    for (const CLI::App* sub : app->get_subcommands()) {
      if (!sub->get_name().empty()) {  // an option group is part of its command
        next = sub;
        break;
      }
    }
    app = next;
  }
  return chain;
}

std::string CommandLineMessage(const std::exception& error, const std::vector<const CLI::App*>& commands) {
  const auto* field_error = dynamic_cast<const FieldValueError*>(&error);
  if (field_error == nullptr) return error.what();
  const std::vector<const CLI::Option*> options = OptionsOf(commands);
  const CLI::Option* option = OptionSetting(options, field_error->where(), field_error->field());
  if (option == nullptr) return error.what();
  // A flag has no value to show: "--gltf-displaced-mesh: needs preset gltf".
  const bool flag = option->get_type_size() == 0;
  // A value the user did not type is the option's default: say so, it is what to change.
  const std::string value = flag ? "" : " " + field_error->value() + (option->count() == 0 ? " (the default)" : "");
  return option->get_name() + value + ": " + NameFieldsInRule(field_error->rule(), options, field_error->where());
}

std::string CommandLineMessage(const std::exception& error) {
  if (Root() == nullptr) return error.what();
  return CommandLineMessage(error, ParsedCommands(Root()));
}

}  // namespace scanbench
