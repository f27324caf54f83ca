#pragma once
#include <Eigen/SparseCore>
#include <string>

namespace slamkit {

/// An information matrix as an information filter holds it, with what it shows, e.g. "before
/// sparsification" and "after": a panel of the picture plot/information_matrix_svg.hpp draws.
struct InformationMatrixPanel {
  std::string title;
  /// Symmetric with both triangles stored (what is stored is what is drawn, so a lone triangle shows
  /// as one), rows 0..2 the vehicle's pose, then two rows per landmark in index order.
  Eigen::SparseMatrix<double> information;
};

}  // namespace slamkit
