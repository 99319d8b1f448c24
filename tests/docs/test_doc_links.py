"""Every relative link of the project's Markdown pages leads somewhere.

A link to a file must name a file or folder git knows; a link with an anchor (``page.md#part``
or ``#part``) must name a heading of that page, as GitHub makes anchors from headings (lower
case, punctuation dropped, spaces to hyphens, ``-1``, ``-2`` for repeats).
"""
import os
import re
import subprocess
import unicodedata
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
LINK = re.compile(r'(?<!!)\[[^\]]*\]\(([^)\s]+)\)|!\[[^\]]*\]\(([^)\s]+)\)')
HEADING = re.compile(r'^(#{1,6})\s+(.*?)\s*#*\s*$')
FENCE = re.compile(r'^\s*(```|~~~)')


def tracked(pattern):
    """Paths git knows that match a pathspec, relative to the repository."""
    out = subprocess.run(['git', 'ls-files', pattern], cwd=REPO, check=True,
                         capture_output=True, text=True).stdout
    return [Path(p) for p in out.split()]


def prose_lines(text):
    """The lines of a Markdown text outside fenced code blocks."""
    inside = False
    for line in text.splitlines():
        if FENCE.match(line):
            inside = not inside
            continue
        if not inside:
            yield line


def slug(heading):
    """GitHub's anchor for a heading's text."""
    text = re.sub(r'`([^`]*)`', r'\1', heading)
    text = re.sub(r'\[([^\]]*)\]\([^)]*\)', r'\1', text)
    text = text.strip().lower()
    kept = []
    for ch in text:
        if ch in '-_ ' or unicodedata.category(ch)[0] in 'LN':
            kept.append(ch)
    return ''.join(kept).replace(' ', '-')


def anchors(page):
    """Every anchor GitHub gives the headings of a Markdown page."""
    seen = {}
    result = set()
    for line in prose_lines(page.read_text(encoding='utf-8')):
        m = HEADING.match(line)
        if not m:
            continue
        base = slug(m.group(2))
        n = seen.get(base, 0)
        seen[base] = n + 1
        result.add(base if n == 0 else f'{base}-{n}')
    return result


def links(text):
    """(line number, target) of every link in a page's prose (code spans and blocks left out)."""
    inside = False
    for number, line in enumerate(text.splitlines(), start=1):
        if FENCE.match(line):
            inside = not inside
            continue
        if inside:
            continue
        line = re.sub(r'`[^`]*`', '', line)
        for m in LINK.finditer(line):
            yield number, m.group(1) or m.group(2)


PAGES = [p for p in tracked('*.md') if not str(p).startswith('build')]
KNOWN = {str(p) for p in tracked('*')}
KNOWN_DIRS = {str(parent) for p in KNOWN for parent in Path(p).parents}


def test_the_pages_are_found():
    """The check sees the front page and the docs, so it cannot pass by reading nothing."""
    names = {str(p) for p in PAGES}
    assert 'README.md' in names and 'docs/README.md' in names and len(names) >= 15


def test_slug_follows_github():
    """Anchors as GitHub makes them, on headings of the kind these pages use."""
    assert slug('Flying on mlmap') == 'flying-on-mlmap'
    assert slug('Containers (Docker)') == 'containers-docker'
    assert slug('Cost of encryption: 30 Hz clouds') == 'cost-of-encryption-30-hz-clouds'
    assert slug('`mlmap_node` in a colcon workspace') == 'mlmap_node-in-a-colcon-workspace'
    assert slug('360° LiDAR') == '360-lidar'


def broken_links(page, text):
    """The relative links of `text`, read as the page at `page`, that lead nowhere."""
    broken = []
    for number, target in links(text):
        if re.match(r'^[a-z][a-z0-9+.-]*:', target):  # http:, https:, mailto:
            continue
        path, _, anchor = target.partition('#')
        target_page = REPO / page
        if path:
            normal = os.path.normpath(str(page.parent / path))
            if normal not in KNOWN and normal not in KNOWN_DIRS:
                broken.append(f'{page}:{number}: {target} (no such file)')
                continue
            target_page = REPO / normal
        if anchor and target_page.suffix == '.md' and anchor not in anchors(target_page):
            broken.append(f'{page}:{number}: {target} (no such heading)')
    return broken


def test_a_broken_link_is_found():
    """A missing file and a missing heading are reported; a good link and a web link are not."""
    text = ('[a](docs/no-such-page.md) [b](docs/testing.md#no-such-heading)\n'
            '[c](docs/testing.md#how-long-it-takes) [d](https://example.org/x#y)\n'
            '```\n[e](inside-a-code-block.md)\n```\n')
    assert broken_links(Path('README.md'), text) == [
        'README.md:1: docs/no-such-page.md (no such file)',
        'README.md:1: docs/testing.md#no-such-heading (no such heading)']


@pytest.mark.parametrize('page', PAGES, ids=str)
def test_relative_links_resolve(page):
    """Each relative link names a tracked file or folder and, with an anchor, a heading."""
    broken = broken_links(page, (REPO / page).read_text(encoding='utf-8'))
    assert not broken, '\n'.join(broken)
