#pragma once
// The picture of an information matrix's sparsity pattern that explains SEIF (Thrun et al. 2004,
// "Simultaneous localization and mapping with sparse extended information filters", the figure of the
// information matrix before and after sparsification): which variables are linked, and how strongly.
//
// Raw entries of an information matrix are not comparable across variables (their units and scales
// differ), so each entry is shown as the magnitude of the partial correlation it implies,
// |Omega_ij| / sqrt(Omega_ii * Omega_jj), in [0, 1] with 1 on the diagonal. That is the quantity whose
// smallness justifies sparsification, so "a light cell" means "a weak link the filter may drop".
//
// The unit of the picture is a variable (the vehicle's 3 rows, a landmark's 2), not a row: a landmark
// is linked or not as a whole, and a row-level picture would double the pixels without saying more.
// A large map (tens of thousands of landmarks) is binned so that the picture, and the file, stay of a
// bounded size whatever the matrix holds.
#include <cstddef>
#include <span>
#include <string>

#include "slamkit/core/information_matrix.hpp"

namespace slamkit {

/// The panels side by side in one SVG document, each a square picture with its own caption (the
/// matrix's size, its stored non-zeros and the share of variable pairs linked) and one legend for all.
///
/// A cell covers one variable by one or, with more variables than `max_cells`, runs of landmarks
/// consecutive by index, so that a picture has at most max_cells x max_cells cells. The vehicle
/// keeps a row and a column of its own (but with max_cells = 1): its links to the active landmarks
/// are what SEIF's sparsification acts on. A cell of many pairs shows their largest normalised
/// magnitude, since a strong link must not be averaged away by the empty pairs around it. Only
/// non-empty cells are written (one <rect> each), so the file grows with the links, bounded by
/// max_cells^2 per panel, and building it is linear in the stored entries. Entries stored with the
/// value 0 link nothing and are not drawn or counted. A magnitude above 1 (a matrix that is not
/// positive definite) is drawn as 1. Numbers are formatted without the locale, so the same input
/// gives the same bytes anywhere.
///
/// Throws std::invalid_argument, naming the panel, for a matrix that is not square, has fewer than 3
/// rows or an odd number of landmark rows, a diagonal entry that is not positive and finite (naming
/// its row) or a non-finite entry elsewhere; and for no panels or max_cells < 1.
std::string information_matrix_svg(std::span<const InformationMatrixPanel> panels, std::size_t max_cells = 300);

/// information_matrix_svg() written to `path` as a whole or not at all (a viewer or a later step must
/// never see half a picture); InputError naming the path if it cannot be written.
void write_information_matrix_svg(const std::string& path, std::span<const InformationMatrixPanel> panels,
                                  std::size_t max_cells = 300);

}  // namespace slamkit
