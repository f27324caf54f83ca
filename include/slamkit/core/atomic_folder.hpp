#pragma once
// An output folder that is replaced as a whole or not at all, and the lock that gives one process at
// a time the right to write it. AtomicFile makes each file appear complete; a folder of files that
// belong together (a run: its trajectory, map, covariances and run.json) needs the same for the set,
// or a rerun that fails half-way (disk full) leaves new files beside old ones that look like one run.
//
// The new contents are written into a sibling folder `<folder>.partial-<pid>` (holding a file
// INCOMPLETE that says so) and moved over `<folder>` by commit(); until then `<folder>` keeps what it
// held. Everything happens under a FolderLock, so the process holding it knows that every temporary
// of the folder (sibling `.partial-<pid>` staging folders, AtomicFile temporaries inside it) was left
// by a writer that died: the staging folders it removes, the temporaries go with the folder it
// replaces. commit() moves the old folder aside, the new one in, and then deletes the old; a process
// killed between the two moves leaves `<folder>.old-<pid>`, which the next writer puts back.
#include <string>

namespace slamkit {

/// Exclusive use of an output folder for as long as the object lives: an advisory lock (flock) on
/// `<folder>.lock` beside it, which holds this process's id for the error message of the next
/// writer. The kernel drops the lock when the process ends, however it ends, so a killed writer
/// never leaves a folder locked; its lock file is taken over by the next writer. Two FolderLocks of
/// one folder exclude each other within a process as well.
class FolderLock {
 public:
  /// Creates the folder's parent if needed. Throws InputError naming `folder` and the process that
  /// holds it if another one does, or naming the lock file if it cannot be created or locked.
  explicit FolderLock(const std::string& folder);
  /// Unlocks and removes the lock file.
  ~FolderLock();
  FolderLock(const FolderLock&) = delete;
  FolderLock& operator=(const FolderLock&) = delete;

 private:
  void release();

  std::string path_;
  int fd_ = -1;
};

/// The file a folder being written holds until commit(): what read_run and require_complete_folder
/// look for.
inline constexpr const char* kIncompleteMarker = "INCOMPLETE";

class AtomicFolder {
 public:
  /// Takes the folder's lock, clears what killed writers left, and creates the staging folder.
  /// `identifying_file` is the file every folder of this kind holds (run.json): an existing folder
  /// that is not empty and lacks it is not one of ours (`--out .` by mistake) and is refused with an
  /// InputError rather than replaced, as is a path that is not a folder.
  AtomicFolder(const std::string& folder, const std::string& identifying_file);
  /// Removes the staging folder unless commit() has run; the previous folder stays as it was.
  ~AtomicFolder();
  AtomicFolder(const AtomicFolder&) = delete;
  AtomicFolder& operator=(const AtomicFolder&) = delete;

  /// Where the new contents are written.
  const std::string& path() const { return staging_; }
  /// Replaces the folder with the staging folder; InputError naming the folder if it cannot.
  void commit();

 private:
  FolderLock lock_;
  std::string given_, final_, staging_;
  bool committed_ = false;
};

/// Throws InputError naming `folder` if it holds kIncompleteMarker: the staging folder of a writer
/// that has not finished or was killed, whose files do not make a whole.
void require_complete_folder(const std::string& folder);

}  // namespace slamkit
