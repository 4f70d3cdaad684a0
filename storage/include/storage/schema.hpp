#pragma once
// Schema identity and the default location of the history database (docs/storage.md).
#include <cstdint>
#include <filesystem>

namespace alc::storage {

// PRAGMA application_id of every ALC history database: "ALCH" in ASCII.
inline constexpr std::int32_t kApplicationId = 0x414C4348;
// PRAGMA user_version written by this build. Older versions are migrated forward on open by a
// writer; newer ones are refused.
inline constexpr int kSchemaVersion = 5;

// $XDG_DATA_HOME/alc/history.sqlite, else $HOME/.local/share/alc/history.sqlite, else
// ./alc-history.sqlite (no HOME: a service account or a container).
std::filesystem::path default_history_path();

}  // namespace alc::storage

#include <string_view>

namespace alc::storage {

// The SQL that takes schema version `to_version - 1` to `to_version` (1 ≤ to_version ≤
// kSchemaVersion). Version 1 creates the base tables; version 2 adds nc_commands; version 3 adds
// nc_commands.delivered and delivery_message; version 4 the study tables; version 5 run_indicators.
// Exposed so that tests can build a database of an old version exactly as that version did.
std::string_view migration_sql(int to_version);

}  // namespace alc::storage
