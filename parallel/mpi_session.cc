#include "parallel/mpi_session.h"

#include <mpi.h>

#include <algorithm>
#include <cstdlib>
#include <limits>

namespace simplexdb {
namespace {

MpiSession* current = nullptr;

std::string ErrorText(int code) {
  char text[MPI_MAX_ERROR_STRING];
  int n = 0;
  if (MPI_Error_string(code, text, &n) != MPI_SUCCESS) return "MPI error " + std::to_string(code);
  return std::string(text, static_cast<size_t>(n));
}

// MPI's failures are the transport's: IOError, as the operating system's.
Status Check(int code, const char* call) {
  if (code == MPI_SUCCESS) return Status::OK();
  return Status::IOError(std::string(call) + ": " + ErrorText(code));
}

Status WithCode(Status::Code code, const std::string& message) {
  switch (code) {
    case Status::Code::kInvalidArgument: return Status::InvalidArgument(message);
    case Status::Code::kNotFound: return Status::NotFound(message);
    case Status::Code::kCorruption: return Status::Corruption(message);
    case Status::Code::kNotSupported: return Status::NotSupported(message);
    case Status::Code::kResourceExhausted: return Status::ResourceExhausted(message);
    case Status::Code::kOk:
    case Status::Code::kIOError: break;
  }
  return Status::IOError(message);
}

}  // namespace

bool MpiSession::Launched() {
  for (const char* name : {"OMPI_COMM_WORLD_RANK", "PMI_RANK", "PMIX_RANK"}) {
    if (std::getenv(name) != nullptr) return true;
  }
  return std::getenv("SLURM_PROCID") != nullptr && std::getenv("SLURM_NTASKS") != nullptr;
}

Result<std::unique_ptr<MpiSession>> MpiSession::Start(int* argc, char*** argv) {
  int provided = 0;
  SDB_RETURN_IF_ERROR(Check(MPI_Init_thread(argc, argv, MPI_THREAD_FUNNELED, &provided), "MPI_Init_thread"));
  MPI_Comm_set_errhandler(MPI_COMM_WORLD, MPI_ERRORS_RETURN);
  int rank = 0, size = 1;
  SDB_RETURN_IF_ERROR(Check(MPI_Comm_rank(MPI_COMM_WORLD, &rank), "MPI_Comm_rank"));
  SDB_RETURN_IF_ERROR(Check(MPI_Comm_size(MPI_COMM_WORLD, &size), "MPI_Comm_size"));
  MPI_Comm local;
  int local_size = 1;
  SDB_RETURN_IF_ERROR(Check(MPI_Comm_split_type(MPI_COMM_WORLD, MPI_COMM_TYPE_SHARED, rank, MPI_INFO_NULL, &local),
                            "MPI_Comm_split_type"));
  SDB_RETURN_IF_ERROR(Check(MPI_Comm_size(local, &local_size), "MPI_Comm_size"));
  MPI_Comm_free(&local);
  std::unique_ptr<MpiSession> session(new MpiSession(rank, size, local_size));
  current = session.get();
  return session;
}

MpiSession* MpiSession::Current() { return current; }

MpiSession::~MpiSession() {
  current = nullptr;
  MPI_Finalize();
}

Status MpiSession::PeerFailed() { return Status::IOError("stopped: another rank failed"); }

Result<std::vector<uint64_t>> MpiSession::Exchange(const std::vector<std::vector<uint64_t>>& outbox, bool failed,
                                                   bool* quiet) {
  const size_t n = static_cast<size_t>(size_);
  std::vector<int> send_counts(n), recv_counts(n), send_at(n), recv_at(n);
  std::vector<uint64_t> sent;
  uint64_t total_out = 0;
  for (const auto& box : outbox) total_out += box.size();
  // MPI counts are ints: more than that fails this rank, which sends
  // nothing but still joins the round, so that every rank stops.
  const bool too_many = total_out > static_cast<uint64_t>(INT32_MAX);
  for (size_t r = 0; r < n && !too_many; ++r) {
    send_at[r] = static_cast<int>(sent.size());
    send_counts[r] = static_cast<int>(outbox[r].size());
    sent.insert(sent.end(), outbox[r].begin(), outbox[r].end());
  }
  SDB_RETURN_IF_ERROR(
      Check(MPI_Alltoall(send_counts.data(), 1, MPI_INT, recv_counts.data(), 1, MPI_INT, MPI_COMM_WORLD), "MPI_Alltoall"));
  int total = 0;
  for (size_t r = 0; r < n; ++r) {
    recv_at[r] = total;
    total += recv_counts[r];
  }
  std::vector<uint64_t> received(static_cast<size_t>(total));
  SDB_RETURN_IF_ERROR(Check(MPI_Alltoallv(sent.data(), send_counts.data(), send_at.data(), MPI_UINT64_T,
                                          received.data(), recv_counts.data(), recv_at.data(), MPI_UINT64_T,
                                          MPI_COMM_WORLD),
                            "MPI_Alltoallv"));
  // Codes sent, and ranks that failed, over all ranks.
  const uint64_t mine[2] = {sent.size(), failed || too_many ? 1u : 0u};
  uint64_t all[2] = {0, 0};
  SDB_RETURN_IF_ERROR(Check(MPI_Allreduce(mine, all, 2, MPI_UINT64_T, MPI_SUM, MPI_COMM_WORLD), "MPI_Allreduce"));
  if (too_many) {
    return Status::ResourceExhausted(std::to_string(total_out) + " split codes to send in one round: more than 2^31");
  }
  if (all[1] > 0) return PeerFailed();
  *quiet = all[0] == 0;
  return received;
}

Status MpiSession::Agree(const Status& mine) {
  Count(sizeof(int));
  // Ranks that failed by themselves first, then those that stopped for
  // them, then those that did not fail.
  const bool peer = !mine.ok() && mine.message() == PeerFailed().message();
  const int me = mine.ok() ? 2 * size_ : peer ? size_ + rank_ : rank_;
  int least = 2 * size_;
  SDB_RETURN_IF_ERROR(Check(MPI_Allreduce(&me, &least, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD), "MPI_Allreduce"));
  if (least == 2 * size_) return Status::OK();
  const int first = least % size_;
  // The failing rank's code and message, to every rank.
  std::string text = first == rank_ ? std::string(mine.message()) : std::string();
  int head[2] = {static_cast<int>(mine.code()), static_cast<int>(text.size())};
  SDB_RETURN_IF_ERROR(Check(MPI_Bcast(head, 2, MPI_INT, first, MPI_COMM_WORLD), "MPI_Bcast"));
  text.resize(static_cast<size_t>(head[1]));
  SDB_RETURN_IF_ERROR(Check(MPI_Bcast(text.data(), head[1], MPI_CHAR, first, MPI_COMM_WORLD), "MPI_Bcast"));
  return WithCode(static_cast<Status::Code>(head[0]),
                  "rank " + std::to_string(first) + " of " + std::to_string(size_) + ": " + text);
}

Result<std::vector<std::string>> MpiSession::Gather(const std::string& mine) {
  Count(mine.size());
  const int length = static_cast<int>(mine.size());
  std::vector<int> lengths(static_cast<size_t>(size_)), at(static_cast<size_t>(size_));
  SDB_RETURN_IF_ERROR(
      Check(MPI_Gather(&length, 1, MPI_INT, lengths.data(), 1, MPI_INT, 0, MPI_COMM_WORLD), "MPI_Gather"));
  std::string all;
  if (rank_ == 0) {
    int total = 0;
    for (size_t r = 0; r < lengths.size(); ++r) {
      at[r] = total;
      total += lengths[r];
    }
    all.resize(static_cast<size_t>(total));
  }
  SDB_RETURN_IF_ERROR(Check(MPI_Gatherv(mine.data(), length, MPI_CHAR, all.data(), lengths.data(), at.data(),
                                        MPI_CHAR, 0, MPI_COMM_WORLD),
                            "MPI_Gatherv"));
  std::vector<std::string> out;
  if (rank_ == 0) {
    for (size_t r = 0; r < lengths.size(); ++r) {
      out.push_back(all.substr(static_cast<size_t>(at[r]), static_cast<size_t>(lengths[r])));
    }
  }
  return out;
}

namespace {

// An all-reduce in place, in parts MPI's int counts can name.
template <class T>
Status ReduceInPlace(std::span<T> values, MPI_Datatype type, MPI_Op op) {
  constexpr size_t kPart = size_t{1} << 30;
  for (size_t at = 0; at < values.size(); at += kPart) {
    const int n = static_cast<int>(std::min(kPart, values.size() - at));
    SDB_RETURN_IF_ERROR(
        Check(MPI_Allreduce(MPI_IN_PLACE, values.data() + at, n, type, op, MPI_COMM_WORLD), "MPI_Allreduce"));
  }
  return Status::OK();
}

}  // namespace

Status MpiSession::Broadcast(std::span<uint8_t> bytes, int root) {
  Count(root == rank_ ? bytes.size() : 0);
  constexpr size_t kPart = size_t{1} << 30;
  for (size_t at = 0; at < bytes.size(); at += kPart) {
    const int n = static_cast<int>(std::min(kPart, bytes.size() - at));
    SDB_RETURN_IF_ERROR(Check(MPI_Bcast(bytes.data() + at, n, MPI_BYTE, root, MPI_COMM_WORLD), "MPI_Bcast"));
  }
  return Status::OK();
}

Status MpiSession::Max(std::span<double> values) {
  Count(values.size_bytes());
  return ReduceInPlace(values, MPI_DOUBLE, MPI_MAX);
}
Status MpiSession::Max(std::span<float> values) {
  Count(values.size_bytes());
  return ReduceInPlace(values, MPI_FLOAT, MPI_MAX);
}
Status MpiSession::Or(std::span<uint64_t> words) {
  Count(words.size_bytes());
  return ReduceInPlace(words, MPI_UINT64_T, MPI_BOR);
}

Result<std::string> MpiSession::Scatter(const std::vector<std::string>& parts) {
  uint64_t total_bytes = 0;
  for (const std::string& part : parts) total_bytes += rank_ == 0 ? part.size() : 0;
  Count(total_bytes);
  std::vector<int> lengths(static_cast<size_t>(size_)), at(static_cast<size_t>(size_));
  std::string all;
  if (rank_ == 0) {
    int total = 0;
    for (int r = 0; r < size_; ++r) {
      const std::string& part = parts[static_cast<size_t>(r)];
      if (part.size() > static_cast<size_t>(std::numeric_limits<int>::max() - total)) {
        return Status::ResourceExhausted("MPI_Scatterv: more than 2 GiB to send");
      }
      lengths[static_cast<size_t>(r)] = static_cast<int>(part.size());
      at[static_cast<size_t>(r)] = total;
      total += static_cast<int>(part.size());
      all += part;
    }
  }
  int length = 0;
  SDB_RETURN_IF_ERROR(
      Check(MPI_Scatter(lengths.data(), 1, MPI_INT, &length, 1, MPI_INT, 0, MPI_COMM_WORLD), "MPI_Scatter"));
  std::string mine(static_cast<size_t>(length), '\0');
  SDB_RETURN_IF_ERROR(Check(MPI_Scatterv(all.data(), lengths.data(), at.data(), MPI_CHAR, mine.data(), length,
                                         MPI_CHAR, 0, MPI_COMM_WORLD),
                            "MPI_Scatterv"));
  return mine;
}

}  // namespace simplexdb
