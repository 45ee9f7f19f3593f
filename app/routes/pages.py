"""Server-rendered pages under /ui (Jinja2), on the same API keys and team scoping as /v1.

Sign-in: the login form checks the key and keeps it in the `gnssatt_key` cookie (HttpOnly, SameSite=Strict,
Secure over https), which `app.deps.get_team` already accepts, so the pages' small scripts call /v1 like
any client. Cookie authentication is ambient, so every state-changing request that relies on it must carry
a CSRF token: a random value kept in the HttpOnly `gnssatt_csrf` cookie and repeated by the page (form field
`csrf_token`, or the `X-CSRF-Token` header that the pages' fetch() calls set, read from a <meta> tag).
`CsrfMiddleware` enforces that on /v1; requests that authenticate with `Authorization: Bearer` or `X-API-Key`
(scripts, the CLI) are untouched.

Pages read the database directly (team-scoped like the API) and never run science: plots are products made
by the worker (gnssatt/plots); the interactive charts (static/charts.js, uPlot) read the job's own CSV products
through the download URLs.
"""
from __future__ import annotations

import json
import secrets
from pathlib import Path
from typing import Any
from urllib.parse import quote

from fastapi import APIRouter, FastAPI, Request
from fastapi.responses import HTMLResponse, RedirectResponse, Response
from fastapi.staticfiles import StaticFiles
from fastapi.templating import Jinja2Templates
from sqlalchemy import func, select
from starlette.datastructures import Headers

from app.deps import SessionDep
from app.keys import team_for_key
from app.problems import ProblemError, problem_response
from core.models import Job, JobSet, ObservationSet, PcvMap, Product, Team
from gnssatt.report import format_value

APP_DIR = Path(__file__).resolve().parents[1]
TEMPLATES = Jinja2Templates(directory=str(APP_DIR / "templates"))
STATIC_DIR = APP_DIR / "static"

KEY_COOKIE = "gnssatt_key"
CSRF_COOKIE = "gnssatt_csrf"
CSRF_HEADER = "X-CSRF-Token"
CSRF_FIELD = "csrf_token"
#: How long a browser keeps the key after sign-in [s] (a working day); sign out clears it at once.
KEY_COOKIE_MAX_AGE_S = 8 * 3600
SAFE_METHODS = frozenset({"GET", "HEAD", "OPTIONS", "TRACE"})
TERMINAL = ("succeeded", "failed", "cancelled")
PAGE_SIZE = 50
#: summary.json is read for the job page up to this size [bytes]; larger ones are only linked.
MAX_SUMMARY_BYTES = 2 * 1024 * 1024
#: Content-Security-Policy of every page: nothing from other origins, no inline scripts.
CSP = ("default-src 'self'; script-src 'self'; style-src 'self'; img-src 'self' data: blob:; connect-src 'self'; "
       "font-src 'self'; object-src 'none'; base-uri 'none'; form-action 'self'; frame-ancestors 'none'")

router = APIRouter(prefix="/ui", include_in_schema=False)


# --- wiring --------------------------------------------------------------------------------------------------

def install_pages(app: FastAPI) -> None:
    """Add the /ui pages, the /static assets, `/` -> /ui, the offline API docs (/docs, /redoc from vendored
    Swagger UI and ReDoc), /docs/conventions, and the CSRF guard of cookie-authenticated /v1 calls."""
    from app.job_delete import router as job_delete_router
    from app.webhooks import router as webhooks_router

    install_docs(app)
    app.include_router(router)
    app.include_router(webhooks_router)
    app.include_router(job_delete_router)
    app.mount("/static", StaticFiles(directory=str(STATIC_DIR)), name="static")
    app.add_api_route("/", lambda: RedirectResponse("/ui", status_code=307), methods=["GET"],
                      include_in_schema=False)
    app.add_middleware(CsrfMiddleware)


REPO_DIR = APP_DIR.parent
CONVENTIONS_MD = REPO_DIR / "docs" / "CONVENTIONS.md"


def install_docs(app: FastAPI) -> None:
    """/docs (Swagger UI) and /redoc (ReDoc) from the assets in static/vendor instead of FastAPI's CDN URLs, so
    the API documentation renders without a network; /docs/conventions renders docs/CONVENTIONS.md."""
    from fastapi.openapi.docs import get_redoc_html, get_swagger_ui_html

    app.router.routes[:] = [r for r in app.router.routes if getattr(r, "path", None) not in ("/docs", "/redoc")]
    openapi_url = app.openapi_url or "/openapi.json"

    def swagger(request: Request):
        return get_swagger_ui_html(openapi_url=openapi_url, title=f"{app.title} API",
                                   swagger_js_url="/static/vendor/swagger-ui/swagger-ui-bundle.js",
                                   swagger_css_url="/static/vendor/swagger-ui/swagger-ui.css",
                                   swagger_favicon_url="/static/favicon.svg",
                                   oauth2_redirect_url=app.swagger_ui_oauth2_redirect_url)

    def redoc(request: Request):
        return get_redoc_html(openapi_url=openapi_url, title=f"{app.title} API",
                              redoc_js_url="/static/vendor/redoc/redoc.standalone.js",
                              redoc_favicon_url="/static/favicon.svg", with_google_fonts=False)

    app.add_api_route("/docs", swagger, methods=["GET"], include_in_schema=False)
    app.add_api_route("/redoc", redoc, methods=["GET"], include_in_schema=False)
    app.add_api_route("/docs/conventions", conventions_page, methods=["GET"], include_in_schema=False)


def conventions_html() -> str | None:
    """docs/CONVENTIONS.md as HTML (CommonMark + tables by markdown-it-py; raw HTML in the file is escaped)."""
    from markdown_it import MarkdownIt

    try:
        text = CONVENTIONS_MD.read_text(encoding="utf-8")
    except OSError:
        return None
    return MarkdownIt("commonmark", {"html": False}).enable("table").render(text)


def conventions_page(request: Request, session: SessionDep):
    """The file formats and conventions every error message cites, readable without signing in."""
    body = conventions_html()
    if body is None:
        return problem_page(request, None, ProblemError(404, "not-found", "CONVENTIONS.md missing",
                                                        "docs/CONVENTIONS.md is not in this installation."))
    return render(request, "conventions.html", team=page_team(request, session), body=body)


class CsrfMiddleware:
    """Refuse (403 problem) a state-changing /v1 request authenticated by the `gnssatt_key` cookie alone
    unless its `X-CSRF-Token` header equals the `gnssatt_csrf` cookie (double submit; both cookies are
    SameSite=Strict). Pure ASGI, so streamed uploads pass through untouched."""

    def __init__(self, app):
        self.app = app

    async def __call__(self, scope, receive, send):
        if scope["type"] == "http" and scope["method"] not in SAFE_METHODS and scope["path"].startswith("/v1/"):
            headers = Headers(scope=scope)
            bearer = headers.get("authorization", "")
            explicit = (bearer.lower().startswith("bearer ") and bearer[7:].strip()) or headers.get("x-api-key")
            cookies = _cookies(headers)
            if not explicit and cookies.get(KEY_COOKIE) and not csrf_ok(cookies.get(CSRF_COOKIE),
                                                                        headers.get(CSRF_HEADER)):
                body = ProblemError(403, "csrf-token-invalid", "CSRF token missing or invalid",
                                    "Requests authenticated by the sign-in cookie must send the page's CSRF "
                                    f"token in the {CSRF_HEADER} header. Scripts should authenticate with "
                                    "'Authorization: Bearer KEY' instead.").body(scope["path"])
                await problem_response(403, body)(scope, receive, send)
                return
        await self.app(scope, receive, send)


def _cookies(headers: Headers) -> dict[str, str]:
    from http.cookies import SimpleCookie

    jar: SimpleCookie = SimpleCookie()
    for raw in headers.getlist("cookie"):
        try:
            jar.load(raw)
        except Exception:  # noqa: BLE001 - a malformed cookie header counts as no cookie
            continue
    return {k: m.value for k, m in jar.items()}


def csrf_ok(expected: str | None, given: str | None) -> bool:
    return bool(expected) and bool(given) and secrets.compare_digest(str(expected), str(given))


# --- helpers ---------------------------------------------------------------------------------------------------

def _secure(request: Request) -> bool:
    return request.url.scheme == "https"


def _csrf_token(request: Request) -> str:
    token = request.cookies.get(CSRF_COOKIE)
    if not token or len(token) < 20:
        token = getattr(request.state, "new_csrf", None) or secrets.token_urlsafe(32)
        request.state.new_csrf = token
    return token


def _finish(request: Request, response: Response) -> Response:
    """Security headers of every page, and the CSRF cookie when this request minted one."""
    response.headers["Content-Security-Policy"] = CSP
    response.headers["X-Content-Type-Options"] = "nosniff"
    response.headers["Referrer-Policy"] = "same-origin"
    response.headers["Cache-Control"] = "no-store"
    new = getattr(request.state, "new_csrf", None)
    if new:
        response.set_cookie(CSRF_COOKIE, new, httponly=True, samesite="strict", secure=_secure(request), path="/")
    return response


def render(request: Request, template: str, status_code: int = 200, team: Team | None = None,
           **context: Any) -> Response:
    context.update(team=team, csrf_token=_csrf_token(request), nav=template.split(".")[0])
    return _finish(request, TEMPLATES.TemplateResponse(request, template, context, status_code=status_code))


def page_team(request: Request, session) -> Team | None:
    key = request.cookies.get(KEY_COOKIE)
    return team_for_key(session, key) if key else None


def to_login(request: Request) -> Response:
    target = request.url.path + (f"?{request.url.query}" if request.url.query else "")
    return _finish(request, RedirectResponse(f"/ui/login?next={quote(target, safe='')}", status_code=303))


def problem_page(request: Request, team: Team | None, exc: ProblemError) -> Response:
    return render(request, "error.html", status_code=exc.status, team=team,
                  problem=exc.body(str(request.url.path)))


def _safe_next(target: str | None) -> str:
    """Only same-site page paths are followed after sign-in (no open redirect)."""
    if target and target.startswith("/ui") and not target.startswith("//") and "\\" not in target:
        return target
    return "/ui"


def product_url(job_id: str, name: str) -> str:
    return f"/v1/jobs/{quote(job_id, safe='')}/products/{quote(name, safe='')}"


def job_view(job: Job, set_names: dict[str, str] | None = None) -> dict[str, Any]:
    """A job for the templates; set_names (set id -> name) fills `set_names`, the duration is started to
    finished [s] (None while it runs)."""
    duration = None
    if job.started_at is not None and job.finished_at is not None:
        duration = max((job.finished_at - job.started_at).total_seconds(), 0.0)
    ids = list(job.set_ids or [])
    return {"id": job.id, "type": job.type, "state": job.state, "progress": float(job.progress or 0.0),
            "stage": job.stage, "created_at": job.created_at, "started_at": job.started_at,
            "finished_at": job.finished_at, "attempts": job.attempts, "error": job.error,
            "config": job.config or {}, "set_ids": ids, "terminal": job.state in TERMINAL,
            "duration_s": duration,
            "set_names": [{"id": i, "name": (set_names or {}).get(i) or i[:8]} for i in ids]}


def set_names_of(session, team_id: str, jobs) -> dict[str, str]:
    """Set id -> name (or short id) of the sets the jobs read, in one query."""
    ids = {i for j in jobs for i in (j.set_ids or [])}
    if not ids:
        return {}
    rows = session.execute(select(ObservationSet.id, ObservationSet.name).where(
        ObservationSet.id.in_(list(ids)), ObservationSet.team_id == team_id)).all()
    return {i: (n or i[:8]) for i, n in rows}


def summary_items(summary: Any, prefix: str = "", depth: int = 3) -> list[tuple[str, str]]:
    """(dotted key, text) of the scalar numbers of a summary document; long lists are counted, not shown."""
    items: list[tuple[str, str]] = []
    if not isinstance(summary, dict):
        return items
    for key, value in summary.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            if depth > 1:
                items.extend(summary_items(value, name + ".", depth - 1))
        elif isinstance(value, list):
            if all(not isinstance(v, (dict, list)) for v in value) and len(value) <= 12:
                items.append((name, ", ".join(format_value(v) for v in value)))
            else:
                items.append((name, f"{len(value)} entries"))
        else:
            items.append((name, format_value(value)))
    return items


# --- sign-in ---------------------------------------------------------------------------------------------------

@router.get("/login", response_class=HTMLResponse)
def login_form(request: Request, session: SessionDep, next: str | None = None):
    return render(request, "login.html", team=page_team(request, session), next=_safe_next(next), error=None)


@router.post("/login", response_class=HTMLResponse)
async def login(request: Request, session: SessionDep):
    form = await request.form()
    target = _safe_next(str(form.get("next") or ""))
    if not csrf_ok(request.cookies.get(CSRF_COOKIE), str(form.get(CSRF_FIELD) or "")):
        return render(request, "login.html", status_code=403, next=target,
                      error={"title": "Sign-in form expired", "detail": "Reload the page and sign in again "
                             "(the form's CSRF token did not match; cookies must be enabled)."})
    key = str(form.get("api_key") or "").strip()
    team = team_for_key(session, key) if key else None
    if team is None:
        return render(request, "login.html", status_code=401, next=target,
                      error={"title": "Invalid API key", "detail": "This API key is unknown or revoked. An "
                             "operator mints keys with 'gnssatt admin create-key --team NAME'."})
    response = RedirectResponse(target, status_code=303)
    response.set_cookie(KEY_COOKIE, key, max_age=KEY_COOKIE_MAX_AGE_S, httponly=True, samesite="strict",
                        secure=_secure(request), path="/")
    # a fresh CSRF token per sign-in (no token fixation)
    request.state.new_csrf = secrets.token_urlsafe(32)
    return _finish(request, response)


@router.post("/logout")
async def logout(request: Request):
    form = await request.form()
    if not csrf_ok(request.cookies.get(CSRF_COOKIE), str(form.get(CSRF_FIELD) or "")):
        exc = ProblemError(403, "csrf-token-invalid", "CSRF token missing or invalid", "Reload the page and try again.")
        return problem_page(request, None, exc)
    response = RedirectResponse("/ui/login", status_code=303)
    response.delete_cookie(KEY_COOKIE, path="/", samesite="strict", secure=_secure(request), httponly=True)
    response.delete_cookie(CSRF_COOKIE, path="/", samesite="strict", secure=_secure(request), httponly=True)
    return _finish(request, response)


# --- pages -----------------------------------------------------------------------------------------------------

@router.get("", response_class=HTMLResponse)
def dashboard(request: Request, session: SessionDep, sets_offset: int = 0, jobs_offset: int = 0):
    team = page_team(request, session)
    if team is None:
        return to_login(request)
    sets_offset, jobs_offset = max(0, min(sets_offset, 2**31)), max(0, min(jobs_offset, 2**31))
    sets_q = select(ObservationSet).where(ObservationSet.team_id == team.id)
    jobs_q = select(Job).where(Job.team_id == team.id)
    n_sets = session.execute(select(func.count()).select_from(sets_q.subquery())).scalar_one()
    n_jobs = session.execute(select(func.count()).select_from(jobs_q.subquery())).scalar_one()
    sets = session.execute(sets_q.order_by(ObservationSet.created_at.desc(), ObservationSet.id)
                           .limit(PAGE_SIZE).offset(sets_offset)).scalars().all()
    jobs = session.execute(jobs_q.order_by(Job.created_at.desc(), Job.id)
                           .limit(PAGE_SIZE).offset(jobs_offset)).scalars().all()
    names = set_names_of(session, team.id, jobs)
    return render(request, "dashboard.html", team=team, sets=sets, jobs=[job_view(j, names) for j in jobs],
                  n_sets=n_sets, n_jobs=n_jobs, sets_offset=sets_offset, jobs_offset=jobs_offset,
                  page_size=PAGE_SIZE)


@router.get("/sets/{set_id}", response_class=HTMLResponse)
def set_page(set_id: str, request: Request, session: SessionDep):
    team = page_team(request, session)
    if team is None:
        return to_login(request)
    obs_set = session.get(ObservationSet, set_id)
    if obs_set is None or obs_set.team_id != team.id:
        return problem_page(request, team, ProblemError(404, "not-found", "Observation set not found",
                                                        f"No observation set with id {set_id!r} is visible to "
                                                        "your team."))
    jobs = session.execute(select(Job).join(JobSet, JobSet.job_id == Job.id)
                           .where(JobSet.set_id == set_id, Job.team_id == team.id)
                           .order_by(Job.created_at.desc()).limit(PAGE_SIZE)).scalars().all()
    summary = {k: v for k, v in (obs_set.summary or {}).items() if k != "files"}
    names = set_names_of(session, team.id, jobs)
    return render(request, "set.html", team=team, obs_set=obs_set, files=obs_set.files,
                  summary=summary_items(summary), jobs=[job_view(j, names) for j in jobs])


@router.get("/jobs/{job_id}", response_class=HTMLResponse)
def job_page(job_id: str, request: Request, session: SessionDep):
    team = page_team(request, session)
    if team is None:
        return to_login(request)
    job = session.get(Job, job_id)
    if job is None or job.team_id != team.id:
        return problem_page(request, team, ProblemError(404, "not-found", "Job not found",
                                                        f"No job with id {job_id!r} is visible to your team."))
    products = session.execute(select(Product).where(Product.job_id == job.id).order_by(Product.name)).scalars().all()
    rows = [{"name": p.name, "media_type": p.media_type, "size_bytes": p.size_bytes,
             "url": product_url(job.id, p.name)} for p in products]
    summary, summary_note = None, None
    by_name = {p.name: p for p in products}
    if "summary.json" in by_name:
        p = by_name["summary.json"]
        if p.size_bytes <= MAX_SUMMARY_BYTES:
            try:
                summary = json.loads(request.app.state.blobs.path(p.sha256).read_text())
            except (OSError, ValueError) as exc:
                summary_note = f"summary.json could not be read ({exc.__class__.__name__})"
        else:
            summary_note = "summary.json is large; download it below"
    sets = session.execute(select(ObservationSet).where(ObservationSet.id.in_(list(job.set_ids or [])),
                                                        ObservationSet.team_id == team.id)).scalars().all()
    images = [r for r in rows if r["media_type"] == "image/png"]
    charts = [r for r in rows if r["name"].endswith(".csv")]
    charts = [r for r in rows if r["name"].endswith(".csv") or r["name"] == "charts.json"]
    quality = summary.get("quality") if isinstance(summary, dict) and isinstance(summary.get("quality"), dict) else None
    raw = {k: v for k, v in summary.items() if k != "quality"} if isinstance(summary, dict) else summary
    base = f"/ui/jobs/{quote(job.id, safe='')}"
    from app.webhooks import webhook_view

    return render(request, "job.html", team=team, job=job_view(job), products=rows, images=images,
                  webhook=webhook_view(session, job.id),
                  charts=charts, summary=summary_items(raw) if raw is not None else [],
                  summary_note=summary_note, sets=sets, quality=quality,
                  report_url=f"{base}/report" if "report.html" in by_name else None,
                  pdf_url=f"{base}/report.pdf" if "report.html" in by_name and pdf_available() else None,
                  zip_url=f"{base}/all.zip",
                  config_text=json.dumps(job.config or {}, indent=2, sort_keys=True))


#: Content-Security-Policy of report.html shown inline: its own inline CSS and data: images, nothing else.
REPORT_CSP = "default-src 'none'; style-src 'unsafe-inline'; img-src data:; frame-ancestors 'self'; base-uri 'none'"


def _owned_job(request: Request, session, job_id: str) -> tuple[Team | None, Job | None, Response | None]:
    team = page_team(request, session)
    if team is None:
        return None, None, to_login(request)
    job = session.get(Job, job_id)
    if job is None or job.team_id != team.id:
        return team, None, problem_page(request, team, ProblemError(404, "not-found", "Job not found",
                                                                    f"No job with id {job_id!r} is visible to your team."))
    return team, job, None


def _product(session, job: Job, name: str) -> Product | None:
    return session.execute(select(Product).where(Product.job_id == job.id, Product.name == name)).scalar_one_or_none()


def _report_of(request: Request, session, job_id: str):
    """(team, the report.html Product, None), or (team, None, the page to answer) when the job is not the
    team's or has no report."""
    team, job, early = _owned_job(request, session, job_id)
    if early is not None:
        return team, None, early
    p = _product(session, job, "report.html")
    if p is None:
        return team, None, problem_page(request, team, ProblemError(404, "not-found", "No report",
                                                                     "This job has no report.html."))
    return team, p, None


@router.get("/jobs/{job_id}/report", response_class=HTMLResponse)
def report_inline(job_id: str, request: Request, session: SessionDep):
    """report.html shown in the browser (not downloaded), under a CSP that allows only its inline CSS and images."""
    _, p, early = _report_of(request, session, job_id)
    if early is not None:
        return early
    resp = HTMLResponse(request.app.state.blobs.path(p.sha256).read_text())
    _finish(request, resp)
    resp.headers["Content-Security-Policy"] = REPORT_CSP
    resp.headers["Content-Disposition"] = 'inline; filename="report.html"'
    return resp


def pdf_available() -> bool:
    from app.report_pdf import available

    return available()


@router.get("/jobs/{job_id}/report.pdf")
def report_pdf(job_id: str, request: Request, session: SessionDep):
    """report.html printed to PDF by the system Chromium (app.report_pdf), cached beside the blobs."""
    from app.report_pdf import PdfUnavailable, pdf_of

    team, p, early = _report_of(request, session, job_id)
    if early is not None:
        return early
    try:
        data = pdf_of(request.app.state.blobs.path(p.sha256), p.sha256)
    except PdfUnavailable as exc:
        return problem_page(request, team, ProblemError(503, "pdf-unavailable", "PDF not available", str(exc)))
    return _finish(request, Response(data, media_type="application/pdf", headers={
        "Content-Disposition": f'attachment; filename="report-{p.job_id[:8]}.pdf"'}))


@router.get("/jobs/{job_id}/all.zip")
def download_all(job_id: str, request: Request, session: SessionDep):
    """Every product of the job, its configuration and the versions of the software and of the inputs, in one zip."""
    from app.bundle import job_bundle

    team, job, early = _owned_job(request, session, job_id)
    if early is not None:
        return early
    products = session.execute(select(Product).where(Product.job_id == job.id).order_by(Product.name)).scalars().all()
    sets = session.execute(select(ObservationSet).where(ObservationSet.id.in_(list(job.set_ids or [])),
                                                        ObservationSet.team_id == team.id)).scalars().all()
    data = job_bundle(job, products, sets, request.app.state.blobs.path)
    return _finish(request, Response(data, media_type="application/zip", headers={
        "Content-Disposition": f'attachment; filename="gnssatt-{job.id[:8]}.zip"'}))


@router.get("/new", response_class=HTMLResponse)
def new_page(request: Request, session: SessionDep, set: str | None = None):
    team = page_team(request, session)
    if team is None:
        return to_login(request)
    sets = session.execute(select(ObservationSet).where(ObservationSet.team_id == team.id)
                           .order_by(ObservationSet.created_at.desc()).limit(200)).scalars().all()
    return render(request, "new.html", team=team, sets=sets, selected=set)


@router.get("/pcv-maps", response_class=HTMLResponse)
def pcv_maps_page(request: Request, session: SessionDep):
    team = page_team(request, session)
    if team is None:
        return to_login(request)
    maps = session.execute(select(PcvMap).where(PcvMap.team_id == team.id)
                           .order_by(PcvMap.platform, PcvMap.name, PcvMap.version.desc())).scalars().all()
    return render(request, "pcv_maps.html", team=team, maps=maps)


def pcv_map_stats(doc: dict) -> list[tuple[str, str]]:
    """Summary rows of a PCV map JSON (CONVENTIONS.md layout): filled bins, value range, RMS, median sigma."""
    import numpy as np

    values = np.array([[np.nan if v is None else v for v in row] for row in doc["values_mm"]], dtype=float)
    sigma = np.array([[np.nan if v is None else v for v in row] for row in doc["sigma_mm"]], dtype=float)
    count = np.asarray(doc["count"], dtype=np.int64)
    filled = np.isfinite(values)
    rows = [("grid", f"{len(doc['azimuth_deg'])} azimuth x {len(doc['elevation_deg'])} elevation bins"),
            ("filled bins", f"{int(filled.sum())} of {values.size}"),
            ("samples", f"{int(count.sum())}")]
    if filled.any():
        v = values[filled]
        rows += [("values", f"{v.min():.2f} to {v.max():.2f} mm (peak to peak {v.max() - v.min():.2f} mm)"),
                 ("RMS", f"{float(np.sqrt(np.mean(v ** 2))):.2f} mm"),
                 ("median sigma", f"{float(np.nanmedian(sigma[filled])):.2f} mm")]
    return rows


@router.get("/pcv-maps/{map_id}", response_class=HTMLResponse)
def pcv_map_page(map_id: str, request: Request, session: SessionDep):
    """One PCV map: an interactive polar view (value, sigma and sample count of the bin under the pointer)."""
    team = page_team(request, session)
    if team is None:
        return to_login(request)
    row = session.get(PcvMap, map_id)
    if row is None or row.team_id != team.id:
        return problem_page(request, team, ProblemError(404, "not-found", "PCV map not found",
                                                        f"No PCV map with id {map_id!r} is visible to your team."))
    try:
        doc = json.loads(request.app.state.blobs.path(row.sha256).read_bytes())
        stats = pcv_map_stats(doc)
    except (OSError, ValueError, KeyError, TypeError) as exc:
        return problem_page(request, team, ProblemError(
            500, "pcv-map-unreadable", "PCV map cannot be read",
            f"The stored map of {row.name!r} v{row.version} could not be read ({exc.__class__.__name__}); "
            "download it through the API or upload it again."))
    # the map goes into the page as JSON; "</" is escaped so the data can never close the script element
    data = json.dumps(doc, separators=(",", ":")).replace("</", "<\\/")
    return render(request, "pcv_map.html", team=team, m=row, stats=stats, map_json=data)
