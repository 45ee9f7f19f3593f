"""Validate a staged upload as an observation set, then keep it: blobs first, rows in one transaction."""
from __future__ import annotations

from dataclasses import dataclass

from sqlalchemy.orm import Session

from app.problems import ProblemError
from app.store.guard import ExpansionBudget, plain_file, scan_plain
from app.store.plausible import check_plausible
from app.store.summarizer import identify_elsewhere
from app.store.uploads import StagedUpload
from core.blobs import BlobStore
from core.models import ObservationSet, SetFile
from core.settings import Settings
from gnssatt.gnss.io.errors import ParseError
from gnssatt.gnss.io.observation_set import IdentifiedFile, SetProblem, set_summary
from gnssatt.gnss.io.sniff import identify


@dataclass
class ValidatedFile:
    name: str
    kind: str
    summary: dict
    sha256: str
    size_bytes: int
    path: object


def _parse_problem(exc: ParseError) -> ProblemError:
    return ProblemError(422, "parse-error", f"{exc.path} could not be read", str(exc),
                        file=exc.path, line=exc.line_no, expected=exc.expected)


def validate_staged(staged: StagedUpload, settings: Settings,
                    budget: ExpansionBudget | None = None) -> tuple[list[ValidatedFile], dict]:
    """Identify and check every file, and the set as a whole; 422 naming file (and line) otherwise.

    Each file is first peeled of its compression layers within the upload's budget and scanned for bounds
    (app/store/guard.py); the sniffers then read only that bounded plain text."""
    budget = budget or ExpansionBudget(settings)
    files: list[ValidatedFile] = []
    scratch = staged.root / "plain"
    scratch.mkdir(exist_ok=True)
    for f in staged.files:
        plain, layers = plain_file(f.path, f.name, budget, scratch)
        full_read = scan_plain(plain, f.name, settings)
        try:
            if full_read and settings.summarizer_memory_mb:
                kind, summary = identify_elsewhere(plain, f.name, settings.summarizer_memory_mb)
            else:
                kind, summary = identify(plain, f.name)
            check_plausible(kind, summary, plain, f.name)
        except ParseError as exc:
            raise _parse_problem(exc) from exc
        except (OSError, EOFError, ValueError, OverflowError, TypeError, IndexError, RecursionError) as exc:
            raise ProblemError(422, "unreadable-file", f"{f.name} could not be read",
                               f"{f.name}: {type(exc).__name__}: {str(exc)[:300]}", file=f.name) from exc
        finally:
            if plain != f.path:
                plain.unlink(missing_ok=True)
        if "hatanaka" in layers and kind == "rinex_obs":
            summary["compression"] = "hatanaka"
        files.append(ValidatedFile(f.name, kind, summary, f.sha256, f.size_bytes, f.path))
    try:
        summary = set_summary([IdentifiedFile(f.name, f.kind, f.summary, f.path) for f in files])
    except SetProblem as exc:
        raise ProblemError(422, exc.code, exc.title, exc.detail, file=exc.file, field=exc.field) from exc
    except ParseError as exc:
        raise _parse_problem(exc) from exc
    except (OSError, EOFError, ValueError, OverflowError, TypeError, IndexError, RecursionError) as exc:
        raise ProblemError(422, "invalid-set", "The files do not form an observation set",
                           f"{type(exc).__name__}: {str(exc)[:300]}") from exc
    return files, summary


def store_set(session: Session, blobs: BlobStore, team_id: str, name: str | None,
              files: list[ValidatedFile], summary: dict) -> ObservationSet:
    """Move the staged files into the blob store, then insert the set and its files in one transaction, all
    under the store's shared lock (`BlobStore.adding`: the janitor never takes a blob of a set committing)."""
    with blobs.adding():
        for f in files:
            blobs.put_file(f.path, f.sha256)
        obs_set = ObservationSet(team_id=team_id, name=name, platform_name=summary.get("platform"),
                                 total_bytes=sum(f.size_bytes for f in files), summary=summary)
        obs_set.files = [SetFile(name=f.name, kind=f.kind, sha256=f.sha256, size_bytes=f.size_bytes,
                                 summary=f.summary) for f in files]
        session.add(obs_set)
        session.commit()
    session.refresh(obs_set)
    return obs_set
