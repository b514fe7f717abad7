#pragma once
/// The anthropometric tables behind the generator, parsed from the CSV files in models/data/
/// (compiled into the library, so binaries need no data path). Each file's first line names
/// its source.

#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "biodyn/models/character.h"

namespace biodyn::models {

/// One row of de Leva (1996) Table 4.
struct DeLevaRow {
  std::string segment;  ///< "head", "trunk", "upper_trunk", ..., "foot"
  Sex sex = Sex::kMale;
  std::string proximal, distal;  ///< landmarks
  double length_mm = 0;          ///< reference segment length
  double mass_pct = 0;           ///< % of body mass
  double com_pct = 0;            ///< % of length from the proximal landmark
  double r_sag_pct = 0, r_trans_pct = 0, r_long_pct = 0;  ///< radii of gyration, % of length
};

/// One DOF (or ball joint) of joints.csv.
struct JointRow {
  std::string dof;
  JointType type = JointType::kHinge;
  double min_deg = 0, max_deg = 0;
  double tau_ref_Nm = 0;  ///< at the paper's reference subject (179.9 cm, 82.2 kg)
  std::string tau_source;
  double armature = 0, damping = 0;
};

/// All tables, validated.
struct Tables {
  std::vector<DeLevaRow> de_leva;
  std::map<std::string, double> proportions;  ///< body_proportions.csv: name -> value
  std::vector<JointRow> joints;
  std::vector<MarkerPlacement> markers;  ///< markers_26.csv: the thesis's 26

  /// The row for `segment` and `sex`; throws sim::Error if absent.
  const DeLevaRow& de_leva_row(const std::string& segment, Sex sex) const;
  /// A body_proportions.csv value; throws sim::Error if absent.
  double proportion(const std::string& name) const;
  /// A joints.csv row; throws sim::Error if absent.
  const JointRow& joint(const std::string& dof) const;
};

/// Reference stature of de Leva's subjects, m (male 1741 mm, female 1735 mm).
double de_leva_reference_height_m(Sex sex);

/// The tables compiled into the library, parsed once (thread-safe).
const Tables& default_tables();

/// Parses the four CSV texts; `names` are the file names used in errors ("file:line: ...").
/// Throws sim::Error naming file, line, column, what was expected and what was found.
Tables parse_tables(std::string_view de_leva_csv, std::string_view proportions_csv,
                    std::string_view joints_csv, std::string_view markers_csv);

/// Normative adult walking (normative_gait.csv): the sagittal joint angles' mean and SD over
/// the gait cycle, one row per key point (references.md, "Normative adult walking").
struct NormativeGaitRow {
  double percent = 0;                           ///< % of the cycle from heel strike
  double hip_mean_deg = 0, hip_sd_deg = 0;      ///< hip flexion (+)
  double knee_mean_deg = 0, knee_sd_deg = 0;    ///< knee flexion (+)
  double ankle_mean_deg = 0, ankle_sd_deg = 0;  ///< ankle dorsiflexion (+)
};

/// Parses normative_gait.csv's text: rows with increasing percent from 0 to 100, SDs > 0.
/// Throws sim::Error naming the file, line, column, what was expected and what was found.
std::vector<NormativeGaitRow> parse_normative_gait(std::string_view csv);
/// The normative gait compiled into the library, parsed once (thread-safe).
const std::vector<NormativeGaitRow>& normative_gait();

/// The text of an embedded data file by base name ("de_leva_1996.csv"), empty if unknown.
std::string_view embedded_data_file(std::string_view name);

}  // namespace biodyn::models
